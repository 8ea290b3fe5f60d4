#include "client/retry.h"

#include <algorithm>
#include <optional>
#include <random>
#include <thread>

namespace impostor::sdk {

bool IsRetryable(absl::StatusCode code) {
  return code == absl::StatusCode::kUnavailable || code == absl::StatusCode::kDeadlineExceeded;
}

std::chrono::milliseconds BackoffDelay(int attempt) {
  constexpr int64_t kInitialMs = 100;
  constexpr int64_t kMaxMs = 1000;
  int64_t ms = kInitialMs;
  for (int i = 1; i < attempt && ms < kMaxMs; ++i) ms *= 2;
  ms = std::min(ms, kMaxMs);
  thread_local std::minstd_rand rng(std::random_device{}());
  std::uniform_int_distribution<int64_t> jitter(0, ms / 5);
  return std::chrono::milliseconds(ms - jitter(rng));
}

bool RetryPolicy::ShouldRetry(const absl::Status& error) {
  if (!IsRetryable(error.code())) return false;
  ++failures_;
  std::chrono::duration<double> delay = BackoffDelay(failures_);
  bool retry = failures_ < max_attempts_;
  if (error.code() == absl::StatusCode::kUnavailable && max_outage_seconds_ > 0) {
    const std::optional<double> outage = monitor_.OutageSeconds();
    if (outage.has_value() && *outage < max_outage_seconds_) {
      retry = true;
      // The last try comes when the budget ends, not up to a second later.
      delay = std::min(delay, std::chrono::duration<double>(max_outage_seconds_ - *outage));
    }
  }
  if (retry) {
    if (wait_) {
      wait_(delay);
    } else {
      std::this_thread::sleep_for(delay);
    }
  }
  return retry;
}

}  // namespace impostor::sdk
