// Per-token quotas (issue 14): what one token may ask of the farm, so a
// leaked or runaway CI token cannot fill the queue or the disk. Admin
// tokens are exempt; --auth none has no quotas (the old per-client limits
// still apply).
//  - pending jobs: queued or running jobs the token submitted, counted in
//    the job database (BakeScheduler::CountPendingOwnedBy), so durable;
//  - upload bytes per day and bakes (non-cached submits) per hour: sliding
//    windows kept in memory (a restart forgives them). An upload is checked
//    when it starts, so the last one may pass the limit by one blob.
// Refusals are RESOURCE_EXHAUSTED naming the token, the count and the limit.
//
// Thread-safety: every method may be called from any thread.
#ifndef IMPOSTOR_SERVER_TOKEN_QUOTAS_H_
#define IMPOSTOR_SERVER_TOKEN_QUOTAS_H_

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <utility>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"

namespace impostor {

struct QuotaOptions {
  // Defaults: 1,000 pending jobs, 100 GiB uploaded per day, 1,000 bakes per
  // hour per token. Range: >= 1 each.
  int64_t max_pending_jobs = 1000;
  int64_t max_upload_bytes_per_day = int64_t{100} << 30;
  int64_t max_bakes_per_hour = 1000;
};

class TokenQuotas {
 public:
  explicit TokenQuotas(QuotaOptions options, std::function<int64_t()> now_ms = {});

  const QuotaOptions& options() const { return options_; }
  // `pending`: the token's queued or running jobs now.
  absl::Status CheckSubmit(const std::string& token, int64_t pending);
  void RecordBake(const std::string& token);
  absl::Status CheckUpload(const std::string& token);
  void RecordUpload(const std::string& token, int64_t bytes);

 private:
  // Sum of the window's entries younger than `window_ms`, dropping older ones.
  int64_t Sum(std::deque<std::pair<int64_t, int64_t>>& window, int64_t window_ms) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  int64_t Now() const;
  // RESOURCE_EXHAUSTED "<what><used><span>, the limit per token is
  // <limit><unit>" once the window's sum reaches `limit`.
  absl::Status WindowLimit(std::deque<std::pair<int64_t, int64_t>>& window, int64_t window_ms, int64_t limit,
                           const std::string& what, const char* span, const char* unit)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  const QuotaOptions options_;
  const std::function<int64_t()> now_ms_;
  std::mutex mu_;
  // Per token: (Unix ms, amount) entries, oldest first.
  std::map<std::string, std::deque<std::pair<int64_t, int64_t>>> uploads_ ABSL_GUARDED_BY(mu_);
  std::map<std::string, std::deque<std::pair<int64_t, int64_t>>> bakes_ ABSL_GUARDED_BY(mu_);
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_TOKEN_QUOTAS_H_
