#include "server/token_quotas.h"

#include <chrono>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

constexpr int64_t kHourMs = 3'600'000;
constexpr int64_t kDayMs = 24 * kHourMs;

}  // namespace

TokenQuotas::TokenQuotas(QuotaOptions options, std::function<int64_t()> now_ms)
    : options_(options), now_ms_(std::move(now_ms)) {}

int64_t TokenQuotas::Now() const {
  if (now_ms_) return now_ms_();
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

int64_t TokenQuotas::Sum(std::deque<std::pair<int64_t, int64_t>>& window, int64_t window_ms) {
  const int64_t now = Now();
  while (!window.empty() && window.front().first <= now - window_ms) window.pop_front();
  int64_t sum = 0;
  for (const auto& [at, amount] : window) sum += amount;
  return sum;
}

absl::Status TokenQuotas::CheckSubmit(const std::string& token, int64_t pending) {
  if (pending >= options_.max_pending_jobs) {
    return absl::ResourceExhaustedError(absl::StrCat("pending jobs of token '", token, "': ", pending,
                                                     " queued or running, the limit per token is ",
                                                     options_.max_pending_jobs, "; retry once some finish"));
  }
  std::lock_guard lock(mu_);
  return WindowLimit(bakes_[token], kHourMs, options_.max_bakes_per_hour,
                     absl::StrCat("bakes of token '", token, "': "), " in the last hour", " per hour; retry later");
}

void TokenQuotas::RecordBake(const std::string& token) {
  std::lock_guard lock(mu_);
  bakes_[token].emplace_back(Now(), 1);
}

absl::Status TokenQuotas::CheckUpload(const std::string& token) {
  std::lock_guard lock(mu_);
  return WindowLimit(uploads_[token], kDayMs, options_.max_upload_bytes_per_day,
                     absl::StrCat("uploads of token '", token, "': "), " bytes in the last 24 hours", " bytes per day");
}

absl::Status TokenQuotas::WindowLimit(std::deque<std::pair<int64_t, int64_t>>& window, int64_t window_ms, int64_t limit,
                                      const std::string& what, const char* span, const char* unit) {
  const int64_t used = Sum(window, window_ms);
  if (used < limit) return absl::OkStatus();
  return absl::ResourceExhaustedError(absl::StrCat(what, used, span, ", the limit per token is ", limit, unit));
}

void TokenQuotas::RecordUpload(const std::string& token, int64_t bytes) {
  std::lock_guard lock(mu_);
  uploads_[token].emplace_back(Now(), bytes);
}

}  // namespace impostor
