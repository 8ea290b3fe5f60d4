// impostor-server's HTTP side (--http-listen HOST:PORT, off by default):
//   /metrics                 Prometheus text (server/metrics/farm_metrics.h)
//   /healthz, /readyz        for load balancers
//   /api/v1/...              the JSON API (docs/http_api.md)
//   /, /jobs/ID, /results/KEY and /static/...  the dashboard (web/)
// A thin adapter like the gRPC services: every answer is read from the
// scheduler, the blob store and the metrics at request time; it keeps no
// state of its own.
//
// Every request passes through AuthorizeRequest (http_authorize.h) first:
// the single place where a token check goes (with --auth token: a reader,
// submitter or admin token; /login sets it as a cookie for browsers).
//
// Threads: the HTTP library serves requests on its own thread pool; the
// object may be destroyed from any thread (it stops the server and joins).
#ifndef IMPOSTOR_SERVER_HTTP_HTTP_FRONTEND_H_
#define IMPOSTOR_SERVER_HTTP_HTTP_FRONTEND_H_

#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/support/server_interceptor.h>

#include "absl/status/statusor.h"
#include "server/authenticator.h"
#include "server/bake_scheduler.h"
#include "server/blob_store.h"
#include "server/http/http_authorize.h"
#include "server/http/listen_address.h"
#include "server/metrics/farm_metrics.h"

namespace httplib {
class Server;
struct Request;
}

namespace impostor {

class HttpFrontend {
 public:
  struct Options {
    ListenAddress listen;
    // The dashboard's files (web/ of the source tree by default).
    std::filesystem::path static_dir;
    // --auth token: every request but /healthz, /readyz and /login needs a
    // token this checks. Null = --auth none. Must outlive the frontend.
    Authenticator* authenticator = nullptr;
  };

  // Reads --http-listen and --http-static-dir: nullptr when --http-listen is
  // empty (HTTP off); INVALID_ARGUMENT naming the flag for a malformed
  // value, UNAVAILABLE when the address cannot be bound. On success the
  // server is listening and the scheduler reports to its metrics.
  static absl::StatusOr<std::unique_ptr<HttpFrontend>> StartFromFlags(BakeScheduler* scheduler, BlobStore* blobs,
                                                                      Authenticator* authenticator);
  static absl::StatusOr<std::unique_ptr<HttpFrontend>> Start(BakeScheduler* scheduler, BlobStore* blobs,
                                                             Options options);
  ~HttpFrontend();

  // The interceptor that counts RPCs into these metrics, for
  // ServerBuilder::experimental().SetInterceptorCreators.
  std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> InterceptorCreators();
  // Prints "impostor-server http listening on HOST:PORT" to stdout (after
  // the gRPC line, which scripts and tests read first).
  void AnnounceAddress() const;

  int port() const { return port_; }
  FarmMetrics& metrics() { return metrics_; }

 private:
  HttpFrontend(BakeScheduler* scheduler, BlobStore* blobs, Options options);
  void Route();
  // Who asks (http_authorize.h's JobViewer), for what a job shows them.
  JobViewer Viewer(const httplib::Request& req) const;

  BakeScheduler* const scheduler_;
  BlobStore* const blobs_;
  const Options options_;
  FarmMetrics metrics_;
  std::unique_ptr<httplib::Server> server_;
  int port_ = 0;
  std::thread thread_;
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_HTTP_HTTP_FRONTEND_H_
