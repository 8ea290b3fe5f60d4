// The cache's connection to the server, opened on first need rather than
// when the cache opens, so that a game starts (and serves local hits) with
// the server down. After a failed connect, calls within a short window fail
// at once with the same UNAVAILABLE instead of each waiting for a refusal.
//
// Thread-safety: Get may be called from any thread; concurrent first calls
// share one connection attempt. The Transport returned lives as long as
// this object.
#ifndef IMPOSTOR_CLIENT_CACHE_LAZY_TRANSPORT_H_
#define IMPOSTOR_CLIENT_CACHE_LAZY_TRANSPORT_H_

#include <chrono>
#include <memory>
#include <mutex>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "client/transport/transport.h"

namespace impostor::sdk {

class LazyTransport {
 public:
  LazyTransport(ClientOptions options, TransportHooks hooks, double offline_retry_seconds);

  // The connected transport, connecting first if needed. UNAVAILABLE (as
  // Transport::Connect) when the server cannot be reached.
  absl::StatusOr<Transport*> Get();

 private:
  const ClientOptions options_;
  const TransportHooks hooks_;
  const std::chrono::duration<double> offline_retry_;
  std::mutex mu_;  // held during a connection attempt, so others share it
  std::unique_ptr<Transport> transport_ ABSL_GUARDED_BY(mu_);
  absl::Status last_error_ ABSL_GUARDED_BY(mu_);
  std::chrono::steady_clock::time_point last_failure_ ABSL_GUARDED_BY(mu_);
};

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_CACHE_LAZY_TRANSPORT_H_
