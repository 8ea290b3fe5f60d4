// When and how long to wait before trying a failed call again: the backoff,
// and the per-call decision that combines ClientOptions::max_attempts with
// the outage budget (ClientOptions::max_outage_seconds).
#ifndef IMPOSTOR_CLIENT_RETRY_H_
#define IMPOSTOR_CLIENT_RETRY_H_

#include <chrono>
#include <functional>

#include "absl/status/status.h"
#include "client/connection_monitor.h"
#include "impostor/client.h"

namespace impostor::sdk {

// UNAVAILABLE (server down, restarting, network blip) and DEADLINE_EXCEEDED
// are worth another try; every impostor.v1 RPC is idempotent (SubmitBake
// through its request id), so retrying after a deadline cannot bake or
// upload twice. Thread-safe.
bool IsRetryable(absl::StatusCode code);

// Delay before attempt `attempt` + 1 (attempt >= 1 is the one that failed):
// 100 ms doubled per attempt, capped at 1 s, with up to 20% jitter taken off
// so that many clients restarted together do not retry in lockstep. The cap
// matches the channel's reconnect backoff: while the server is down a retry
// fails locally (the channel is in TRANSIENT_FAILURE) and costs the server
// nothing, so the cap only bounds how late a returning server is noticed.
// Thread-safe.
std::chrono::milliseconds BackoffDelay(int attempt);

// The retry decision of one logical call (a unary RPC, an upload, a watch, a
// download), made after each failed attempt. A failure is retried when it
// IsRetryable and either
//  - it is UNAVAILABLE during an outage (see ConnectionMonitor) that has
//    lasted less than max_outage_seconds, or
//  - fewer than max_attempts attempts in a row have failed.
// Not thread-safe: one per call, on the caller's thread.
class RetryPolicy {
 public:
  // How the backoff is waited out: `wait(d)` returns after at most `d`, and
  // may return sooner when the server is back (Transport::WaitForServer).
  using Wait = std::function<void(std::chrono::duration<double>)>;

  RetryPolicy(const ClientOptions& options, const ConnectionMonitor& monitor, Wait wait = {})
      : max_attempts_(options.max_attempts),
        max_outage_seconds_(options.max_outage_seconds),
        monitor_(monitor),
        wait_(std::move(wait)) {}

  // After a failed attempt: waits the backoff (never past the end of the
  // outage budget; with a Wait, until the server is back if that is
  // sooner) and returns true when the call should be tried again; false
  // when `error` is the call's answer.
  bool ShouldRetry(const absl::Status& error);

  // The last attempt made progress (bytes arrived, a stream brought news):
  // the count of failures in a row starts over.
  void MadeProgress() { failures_ = 0; }

  // Failed attempts in a row so far.
  int failures() const { return failures_; }

 private:
  const int max_attempts_;
  const double max_outage_seconds_;
  const ConnectionMonitor& monitor_;
  const Wait wait_;
  int failures_ = 0;
};

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_RETRY_H_
