#include "client/transport/retry.h"

#include <algorithm>
#include <optional>
#include <random>
#include <thread>
#include <utility>
#include <vector>

namespace impostor::sdk {

void CancelSource::Cancel() {
  std::lock_guard lock(mu_);
  if (cancelled_) return;
  cancelled_ = true;
  cancelled_cv_.notify_all();
  // Under the lock: a Registration destroyed meanwhile waits for this run,
  // so a callback never outlives what it points at (a ClientContext).
  for (auto& [id, on_cancel] : callbacks_) on_cancel();
  callbacks_.clear();
}

bool CancelSource::cancelled() const {
  std::lock_guard lock(mu_);
  return cancelled_;
}

bool CancelSource::WaitFor(std::chrono::duration<double> at_most) const {
  std::unique_lock lock(mu_);
  cancelled_cv_.wait_for(lock, at_most, [this]() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) { return cancelled_; });
  return cancelled_;
}

CancelSource::Registration CancelSource::OnCancel(std::function<void()> on_cancel) const {
  {
    std::lock_guard lock(mu_);
    if (!cancelled_) {
      const uint64_t id = next_id_++;
      callbacks_.emplace(id, std::move(on_cancel));
      return Registration(this, id);
    }
  }
  on_cancel();
  return Registration();
}

CancelSource::Registration& CancelSource::Registration::operator=(Registration&& other) noexcept {
  if (this != &other) {
    Reset();
    source_ = std::exchange(other.source_, nullptr);
    id_ = other.id_;
  }
  return *this;
}

void CancelSource::Registration::Reset() {
  if (source_ == nullptr) return;
  std::lock_guard lock(source_->mu_);
  source_->callbacks_.erase(id_);
  source_ = nullptr;
}

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
  if (cancelled() || !IsRetryable(error.code())) return false;
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
    } else if (cancel_ != nullptr) {
      cancel_->WaitFor(delay);
    } else {
      std::this_thread::sleep_for(delay);
    }
  }
  return retry && !cancelled();
}

}  // namespace impostor::sdk
