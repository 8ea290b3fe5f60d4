// Whether the server answers, as the client's calls see it: when an outage
// began (the outage budget of ClientOptions::max_outage_seconds is counted
// from there) and the lost/regained events of
// ClientOptions::on_connection_change, reported once per transition however
// many calls notice.
//
// Thread-safety: every method may be called from any thread. The callback
// runs on the noting thread, serialised with itself, outside the state lock.
#ifndef IMPOSTOR_CLIENT_TRANSPORT_CONNECTION_MONITOR_H_
#define IMPOSTOR_CLIENT_TRANSPORT_CONNECTION_MONITOR_H_

#include <chrono>
#include <functional>
#include <mutex>
#include <optional>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "impostor/client.h"

namespace impostor::sdk {

class ConnectionMonitor {
 public:
  using Callback = std::function<void(const ConnectionEvent&)>;
  ConnectionMonitor(std::string server, double max_outage_seconds, Callback on_change);

  // The server answered: a reply of any code but UNAVAILABLE, or a stream
  // message. Ends an outage under way (kRegained).
  void NoteAnswer();

  // A call failed with `status`. UNAVAILABLE begins an outage unless one is
  // under way (kLost); other codes say nothing about reachability (a
  // DEADLINE_EXCEEDED may be a slow server) and are ignored.
  void NoteFailure(const absl::Status& status);

  // Seconds since the current outage began; nullopt while the server answers.
  std::optional<double> OutageSeconds() const;

 private:
  using Clock = std::chrono::steady_clock;

  const std::string server_;
  const double max_outage_seconds_;
  const Callback on_change_;
  // Held while a transition is decided and reported, so that events arrive
  // in order; taken before mu_.
  std::mutex report_mu_;
  mutable std::mutex mu_;
  std::optional<Clock::time_point> outage_start_ ABSL_GUARDED_BY(mu_);
};

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSPORT_CONNECTION_MONITOR_H_
