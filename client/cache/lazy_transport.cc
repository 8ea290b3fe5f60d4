#include "client/cache/lazy_transport.h"

#include <utility>

namespace impostor::sdk {

LazyTransport::LazyTransport(ClientOptions options, TransportHooks hooks, double offline_retry_seconds)
    : options_(std::move(options)), hooks_(std::move(hooks)), offline_retry_(offline_retry_seconds) {}

absl::StatusOr<Transport*> LazyTransport::Get() {
  std::lock_guard lock(mu_);
  if (transport_ != nullptr) return transport_.get();
  const auto now = std::chrono::steady_clock::now();
  if (!last_error_.ok() && now - last_failure_ < offline_retry_) return last_error_;
  absl::StatusOr<std::unique_ptr<Transport>> transport = Transport::Connect(options_, hooks_);
  if (!transport.ok()) {
    last_error_ = transport.status();
    last_failure_ = std::chrono::steady_clock::now();
    return last_error_;
  }
  transport_ = std::move(*transport);
  last_error_ = absl::OkStatus();
  return transport_.get();
}

}  // namespace impostor::sdk
