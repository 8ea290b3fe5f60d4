// Per-token quotas (issue 14): what one token may ask of the farm, so a
// leaked or runaway CI token cannot fill the queue or the disk. Admin
// tokens are exempt; --auth none has no quotas (the old per-client limits
// still apply).
//  - pending jobs: queued or running jobs the token submitted, counted in
//    the job database (BakeScheduler::CountPendingOwnedBy), so durable;
//  - upload bytes per day and bakes (non-cached submits) per hour: sliding
//    windows of events kept in a QuotaLedger. The server's ledger is the
//    token database (tokens.sqlite3), so a restart forgives nothing. An
//    upload is checked when it starts, so the last one may pass the limit
//    by one blob.
// Refusals are RESOURCE_EXHAUSTED naming the token, the count and the limit.
//
// Thread-safety: every method of TokenQuotas and of the ledgers may be
// called from any thread.
#ifndef IMPOSTOR_SERVER_STORE_TOKEN_QUOTAS_H_
#define IMPOSTOR_SERVER_STORE_TOKEN_QUOTAS_H_

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace impostor {

struct QuotaOptions {
  // Defaults: 1,000 pending jobs, 100 GiB uploaded per day, 1,000 bakes per
  // hour per token. Range: >= 1 each.
  int64_t max_pending_jobs = 1000;
  int64_t max_upload_bytes_per_day = int64_t{100} << 30;
  int64_t max_bakes_per_hour = 1000;
};

// Where the windows' events live: (token, kind, Unix ms, amount) rows. The
// SQLite engine shares the token database; the PostgreSQL engine
// (postgres/postgres_token_store.h) is the shared state of several server
// replicas, so a token's events are counted once whichever replica served
// the call. token_store_factory.h picks the engine.
class QuotaLedger {
 public:
  virtual ~QuotaLedger() = default;
  // Adds an event of `amount` for `token`'s `kind` ("bakes", "upload_bytes").
  // INVALID_ARGUMENT from ValidateQuotaEvent.
  virtual absl::Status Record(const std::string& token, std::string_view kind, int64_t at_ms, int64_t amount) = 0;
  // The sum of `token`'s `kind` events later than `after_ms`.
  virtual absl::StatusOr<int64_t> Sum(const std::string& token, std::string_view kind, int64_t after_ms) = 0;
  // Drops every event at or before `up_to_ms` (none can count any more).
  virtual absl::Status Forget(int64_t up_to_ms) = 0;
};

// What every ledger's Record checks: a token name (ValidateTokenName), a
// kind of the two above, an amount >= 0. INVALID_ARGUMENT naming the field.
absl::Status ValidateQuotaEvent(const std::string& token, std::string_view kind, int64_t amount);

// Events in memory (tests; a server without a data directory).
std::unique_ptr<QuotaLedger> NewInMemoryQuotaLedger();
// Events in DIR/tokens.sqlite3, table quota_events. INTERNAL naming the
// file when it cannot be opened.
absl::StatusOr<std::unique_ptr<QuotaLedger>> OpenSqliteQuotaLedger(const std::filesystem::path& data_dir);

class TokenQuotas {
 public:
  // `now_ms`: Unix ms (empty = the system clock). `ledger`: null = in memory.
  explicit TokenQuotas(QuotaOptions options, std::function<int64_t()> now_ms = {},
                       std::unique_ptr<QuotaLedger> ledger = nullptr);

  const QuotaOptions& options() const { return options_; }
  // `pending`: the token's queued or running jobs now. RESOURCE_EXHAUSTED
  // over a limit; the ledger's error when it cannot be read.
  absl::Status CheckSubmit(const std::string& token, int64_t pending);
  void RecordBake(const std::string& token);
  absl::Status CheckUpload(const std::string& token);
  void RecordUpload(const std::string& token, int64_t bytes);

 private:
  int64_t Now() const;
  // RESOURCE_EXHAUSTED "<what><used><span>, the limit per token is
  // <limit><unit>", with error reason `reason`, once the window's sum
  // reaches `limit`.
  absl::Status WindowLimit(const std::string& token, std::string_view kind, int64_t window_ms, int64_t limit,
                           const std::string& what, const char* span, const char* unit, std::string_view reason);
  // Records an event (a failure is logged: the call it counts succeeded) and
  // forgets day-old events about once a minute.
  void Record(const std::string& token, std::string_view kind, int64_t amount);

  const QuotaOptions options_;
  const std::function<int64_t()> now_ms_;
  const std::unique_ptr<QuotaLedger> ledger_;
  std::atomic<int64_t> last_forget_ms_{0};
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_STORE_TOKEN_QUOTAS_H_
