#include "client/retry.h"

#include <algorithm>
#include <random>
#include <thread>

namespace impostor::sdk {

bool IsRetryable(absl::StatusCode code) {
  return code == absl::StatusCode::kUnavailable || code == absl::StatusCode::kDeadlineExceeded;
}

std::chrono::milliseconds BackoffDelay(int attempt) {
  constexpr int64_t kInitialMs = 100;
  constexpr int64_t kMaxMs = 5000;
  int64_t ms = kInitialMs;
  for (int i = 1; i < attempt && ms < kMaxMs; ++i) ms *= 2;
  ms = std::min(ms, kMaxMs);
  thread_local std::minstd_rand rng(std::random_device{}());
  std::uniform_int_distribution<int64_t> jitter(0, ms / 5);
  return std::chrono::milliseconds(ms - jitter(rng));
}

void SleepBeforeRetry(int attempt) { std::this_thread::sleep_for(BackoffDelay(attempt)); }

}  // namespace impostor::sdk
