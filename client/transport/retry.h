// When and how long to wait before trying a failed call again: the backoff,
// and the per-call decision that combines ClientOptions::max_attempts with
// the outage budget (ClientOptions::max_outage_seconds).
#ifndef IMPOSTOR_CLIENT_TRANSPORT_RETRY_H_
#define IMPOSTOR_CLIENT_TRANSPORT_RETRY_H_

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <utility>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "client/transport/connection_monitor.h"
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

// Stops calls from another thread, at any point: a Cache being closed ends
// its downloads with it. Cancel() wakes every backoff wait of a RetryPolicy
// given this source at once, and TryCancel()s every RPC in flight that was
// given it (Transport::ReadBlob, the unary calls); those calls, and
// ResumeBlobDownload and the like, then return error() (CANCELLED) within
// moments, whatever the server or the link is doing. Cancel is final. One
// source may serve many calls on many threads at once (a Cache's downloads
// share one).
//
// Thread-safety: every method may be called from any thread. The source
// must outlive the calls given it.
class CancelSource {
 public:
  // `reason` is the message of error(), e.g. "the cache is shutting down".
  explicit CancelSource(std::string reason = "cancelled") : reason_(std::move(reason)) {}
  CancelSource(const CancelSource&) = delete;
  CancelSource& operator=(const CancelSource&) = delete;

  // Cancels every call given this source, now and later. Returns once each
  // registered callback (see OnCancel) has run; idempotent.
  void Cancel();
  bool cancelled() const;
  // CANCELLED with the reason given at construction.
  absl::Status error() const { return absl::CancelledError(reason_); }

  // Waits `at_most`, or until Cancel() if that comes first (or came
  // already). Returns cancelled().
  bool WaitFor(std::chrono::duration<double> at_most) const;

  // While the returned Registration lives, Cancel() runs `on_cancel` once,
  // on the cancelling thread, under the source's lock: it must be quick
  // (ClientContext::TryCancel is) and must not use the source. When the
  // source is cancelled already it runs at once, on this thread. A
  // Registration's destructor returns only after a run in progress ended.
  class Registration {
   public:
    Registration() = default;
    Registration(Registration&& other) noexcept : source_(std::exchange(other.source_, nullptr)), id_(other.id_) {}
    Registration& operator=(Registration&& other) noexcept;
    ~Registration() { Reset(); }
    void Reset();

   private:
    friend class CancelSource;
    Registration(const CancelSource* source, uint64_t id) : source_(source), id_(id) {}
    const CancelSource* source_ = nullptr;
    uint64_t id_ = 0;
  };
  [[nodiscard]] Registration OnCancel(std::function<void()> on_cancel) const;

 private:
  const std::string reason_;
  mutable std::mutex mu_;
  mutable std::condition_variable cancelled_cv_;
  bool cancelled_ ABSL_GUARDED_BY(mu_) = false;
  mutable uint64_t next_id_ ABSL_GUARDED_BY(mu_) = 1;
  mutable std::map<uint64_t, std::function<void()>> callbacks_ ABSL_GUARDED_BY(mu_);
};

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
  // may return sooner when the server is back (Transport::WaitForServer) or
  // the call is cancelled.
  using Wait = std::function<void(std::chrono::duration<double>)>;

  // `cancel` (may be null; must outlive the policy): once it is cancelled,
  // ShouldRetry ends its wait at once and answers false. A Wait given too
  // must itself return when `cancel` is cancelled (the transport's does).
  RetryPolicy(const ClientOptions& options, const ConnectionMonitor& monitor, Wait wait = {},
              const CancelSource* cancel = nullptr)
      : max_attempts_(options.max_attempts),
        max_outage_seconds_(options.max_outage_seconds),
        monitor_(monitor),
        wait_(std::move(wait)),
        cancel_(cancel) {}

  // After a failed attempt: waits the backoff (never past the end of the
  // outage budget; with a Wait, until the server is back if that is
  // sooner) and returns true when the call should be tried again; false
  // when `error` is the call's answer, or when the call was cancelled (see
  // cancelled(): the call's answer is then the source's error()).
  bool ShouldRetry(const absl::Status& error);

  // Whether the CancelSource given has been cancelled.
  bool cancelled() const { return cancel_ != nullptr && cancel_->cancelled(); }

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
  const CancelSource* const cancel_;
  int failures_ = 0;
};

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSPORT_RETRY_H_
