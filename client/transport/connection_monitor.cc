#include "client/transport/connection_monitor.h"

#include <utility>

#include "client/base/sdk_log.h"

namespace impostor::sdk {

ConnectionMonitor::ConnectionMonitor(std::string server, double max_outage_seconds, Callback on_change)
    : server_(std::move(server)), max_outage_seconds_(max_outage_seconds), on_change_(std::move(on_change)) {}

void ConnectionMonitor::NoteAnswer() {
  {
    std::lock_guard lock(mu_);
    if (!outage_start_.has_value()) return;  // the common case: nothing changes
  }
  std::lock_guard report(report_mu_);
  ConnectionEvent event;
  {
    std::lock_guard lock(mu_);
    if (!outage_start_.has_value()) return;  // another thread reported it
    event.outage_seconds = std::chrono::duration<double>(Clock::now() - *outage_start_).count();
    outage_start_.reset();
  }
  event.kind = ConnectionEvent::Kind::kRegained;
  event.server = server_;
  event.max_outage_seconds = max_outage_seconds_;
  SdkLog().debug("server {} answers again after {:.1f} s", server_, event.outage_seconds);
  if (on_change_) on_change_(event);
}

void ConnectionMonitor::NoteFailure(const absl::Status& status) {
  if (status.code() != absl::StatusCode::kUnavailable) return;
  {
    std::lock_guard lock(mu_);
    if (outage_start_.has_value()) return;
  }
  std::lock_guard report(report_mu_);
  {
    std::lock_guard lock(mu_);
    if (outage_start_.has_value()) return;
    outage_start_ = Clock::now();
  }
  ConnectionEvent event;
  event.kind = ConnectionEvent::Kind::kLost;
  event.server = server_;
  event.error = status;
  event.max_outage_seconds = max_outage_seconds_;
  SdkLog().debug("lost server {} ({}); retrying for up to {} s", server_, std::string(status.message()),
                 max_outage_seconds_);
  if (on_change_) on_change_(event);
}

std::optional<double> ConnectionMonitor::OutageSeconds() const {
  std::lock_guard lock(mu_);
  if (!outage_start_.has_value()) return std::nullopt;
  return std::chrono::duration<double>(Clock::now() - *outage_start_).count();
}

}  // namespace impostor::sdk
