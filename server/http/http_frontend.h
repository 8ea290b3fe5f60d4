// impostor-server's HTTP side (--http-listen HOST:PORT, off by default):
//   /metrics                 Prometheus text (server/metrics/farm_metrics.h)
//   /healthz, /readyz        for load balancers
//   /api/v1/...              the JSON API (docs/http_api.md)
//   /, /jobs/ID, /results/KEY and /static/...  the dashboard (web/)
//   /releases/v1/...         a release tree as plain static files, the farm
//                            as an origin for game clients' mirrors
//                            (--http-releases; release_response.h)
// A thin adapter like the gRPC services: every answer is read from the
// scheduler, the blob store and the metrics at request time; it keeps no
// state of its own.
//
// Every request passes through AuthorizeRequest (http_authorize.h) first:
// the single place where a token check goes (with --auth token: a reader,
// submitter or admin token; /login sets it as a cookie for browsers). The
// one exception is /releases/, open to all unless
// --http-releases-require-token: its files are named by 256-bit digests
// (nobody guesses one) and game clients carry no farm token.
//
// Threads: the HTTP library serves requests on its own thread pool; the
// object may be destroyed from any thread (it stops the server and joins).
// It owns the release tree's integrity cache (release_files.h), the only
// state it keeps.
#ifndef IMPOSTOR_SERVER_HTTP_HTTP_FRONTEND_H_
#define IMPOSTOR_SERVER_HTTP_HTTP_FRONTEND_H_

#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/support/server_interceptor.h>

#include "absl/status/statusor.h"
#include "server/auth/authenticator.h"
#include "server/scheduler/bake_scheduler.h"
#include "server/blobs/blob_store.h"
#include "server/http/http_authorize.h"
#include "server/http/listen_address.h"
#include "server/http/release_files.h"
#include "server/metrics/farm_metrics.h"

namespace httplib {
class Server;
struct Request;
}

namespace impostor {

// --http-advertise: the front end's base URL as clients reach it (without a
// trailing "/"), which the farm sends with every GetResult answer
// (common/net/farm_http_base.h's kFarmHttpMetadataKey); "" when not given.
// INVALID_ARGUMENT naming the flag without --http-listen, for a malformed
// URL, and for an http:// one when the farm's gRPC is TLS (`grpc_tls`).
absl::StatusOr<std::string> AdvertisedHttpFromFlags(bool grpc_tls);

class HttpFrontend {
 public:
  struct Options {
    ListenAddress listen;
    // The dashboard's files (web/ of the source tree by default).
    std::filesystem::path static_dir;
    // --auth token: every request but /healthz, /readyz and /login needs a
    // token this checks. Null = --auth none. Must outlive the frontend.
    Authenticator* authenticator = nullptr;
    // A release tree to serve under /releases/ (the directory that holds
    // v1/); empty = none.
    std::filesystem::path releases_dir;
    // /releases/ needs a token as the API does (with --auth token); false =
    // open to all.
    bool releases_require_token = false;
  };

  // Reads --http-listen, --http-static-dir, --http-releases and
  // --http-releases-require-token: nullptr when --http-listen is empty (HTTP
  // off); INVALID_ARGUMENT naming the flag for a malformed value, for
  // --http-releases without --http-listen (naming both), for
  // --http-releases-require-token without --http-releases, and for a
  // release directory that is missing or has no v1/ (naming the path);
  // UNAVAILABLE when the address cannot be bound. On success the server is
  // listening and the scheduler reports to its metrics.
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
  // A GET or HEAD of /releases/ that needs no token (see above).
  bool IsOpenRelease(const httplib::Request& req) const;
  // Who asks (http_authorize.h's JobViewer), for what a job shows them.
  JobViewer Viewer(const httplib::Request& req) const;

  BakeScheduler* const scheduler_;
  BlobStore* const blobs_;
  const Options options_;
  FarmMetrics metrics_;
  // Null without --http-releases.
  std::unique_ptr<ReleaseTree> releases_;
  std::unique_ptr<httplib::Server> server_;
  int port_ = 0;
  std::thread thread_;
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_HTTP_HTTP_FRONTEND_H_
