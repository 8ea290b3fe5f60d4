#include "server/store/token_quotas.h"

#include <chrono>
#include <deque>
#include <map>
#include <mutex>
#include <utility>

#include <spdlog/spdlog.h>

#include "absl/base/thread_annotations.h"
#include "absl/strings/str_cat.h"
#include "common/error_reason.h"
#include "server/store/sqlite/sqlite_open.h"
#include "server/store/token_store.h"

namespace impostor {
namespace {

constexpr int64_t kHourMs = 3'600'000;
constexpr int64_t kDayMs = 24 * kHourMs;
constexpr int64_t kForgetEveryMs = 60'000;

class InMemoryQuotaLedger final : public QuotaLedger {
 public:
  absl::Status Record(const std::string& token, std::string_view kind, int64_t at_ms, int64_t amount) override {
    if (auto s = ValidateQuotaEvent(token, kind, amount); !s.ok()) return s;
    std::lock_guard lock(mu_);
    events_[{token, std::string(kind)}].emplace_back(at_ms, amount);
    return absl::OkStatus();
  }
  absl::StatusOr<int64_t> Sum(const std::string& token, std::string_view kind, int64_t after_ms) override {
    std::lock_guard lock(mu_);
    int64_t sum = 0;
    for (const auto& [at, amount] : events_[{token, std::string(kind)}]) sum += at > after_ms ? amount : 0;
    return sum;
  }
  absl::Status Forget(int64_t up_to_ms) override {
    std::lock_guard lock(mu_);
    for (auto& [key, events] : events_) {
      while (!events.empty() && events.front().first <= up_to_ms) events.pop_front();
    }
    return absl::OkStatus();
  }

 private:
  std::mutex mu_;
  // (token, kind) -> (Unix ms, amount), oldest first.
  std::map<std::pair<std::string, std::string>, std::deque<std::pair<int64_t, int64_t>>> events_ ABSL_GUARDED_BY(mu_);
};

// synchronous = NORMAL: in WAL mode a committed event survives a crash of
// the server (the restart this ledger is for); only a power cut may lose the
// last ones, which costs a token a few uncounted uploads, not an fsync per
// upload.
constexpr const char* kLedgerSchema = R"sql(
PRAGMA journal_mode = WAL;
PRAGMA synchronous = NORMAL;
CREATE TABLE IF NOT EXISTS quota_events (
  token  TEXT NOT NULL,     -- token name
  kind   TEXT NOT NULL,     -- bakes, upload_bytes
  at_ms  INTEGER NOT NULL,  -- Unix ms
  amount INTEGER NOT NULL
);
CREATE INDEX IF NOT EXISTS quota_events_window ON quota_events (token, kind, at_ms);
CREATE INDEX IF NOT EXISTS quota_events_age ON quota_events (at_ms);
)sql";

class SqliteQuotaLedger final : public QuotaLedger {
 public:
  explicit SqliteQuotaLedger(sqlite3* db) : db_(db) {}
  ~SqliteQuotaLedger() override { sqlite3_close(db_); }

  absl::Status Record(const std::string& token, std::string_view kind, int64_t at_ms, int64_t amount) override {
    if (auto s = ValidateQuotaEvent(token, kind, amount); !s.ok()) return s;
    std::lock_guard lock(mu_);
    Statement st(db_, "INSERT INTO quota_events (token, kind, at_ms, amount) VALUES (?1, ?2, ?3, ?4)");
    if (!st.ok()) return st.Error("prepare");
    st.Bind(1, token);
    st.Bind(2, std::string(kind));
    st.Bind(3, at_ms);
    st.Bind(4, amount);
    if (st.Step() != SQLITE_DONE) return st.Error("insert");
    return absl::OkStatus();
  }
  absl::StatusOr<int64_t> Sum(const std::string& token, std::string_view kind, int64_t after_ms) override {
    std::lock_guard lock(mu_);
    Statement st(db_, "SELECT COALESCE(SUM(amount), 0) FROM quota_events WHERE token = ?1 AND kind = ?2 AND at_ms > ?3");
    if (!st.ok()) return st.Error("prepare");
    st.Bind(1, token);
    st.Bind(2, std::string(kind));
    st.Bind(3, after_ms);
    if (st.Step() != SQLITE_ROW) return st.Error("query");
    return st.Int(0);
  }
  absl::Status Forget(int64_t up_to_ms) override {
    std::lock_guard lock(mu_);
    Statement st(db_, "DELETE FROM quota_events WHERE at_ms <= ?1");
    if (!st.ok()) return st.Error("prepare");
    st.Bind(1, up_to_ms);
    if (st.Step() != SQLITE_DONE) return st.Error("forget");
    return absl::OkStatus();
  }

 private:
  class Statement : public SqliteStatement {
   public:
    Statement(sqlite3* db, const char* sql) : SqliteStatement(db, sql, "quota ledger") {}
  };
  std::mutex mu_;  // one connection, serialised
  sqlite3* const db_;
};

}  // namespace

absl::Status ValidateQuotaEvent(const std::string& token, std::string_view kind, int64_t amount) {
  if (auto s = ValidateTokenName(token); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("quota token: ", s.message()));
  }
  if (kind != "bakes" && kind != "upload_bytes") {
    return absl::InvalidArgumentError(
        absl::StrCat("quota kind: \"", std::string(kind), "\" is not bakes or upload_bytes"));
  }
  if (amount < 0) return absl::InvalidArgumentError(absl::StrCat("quota amount: ", amount, " is negative"));
  return absl::OkStatus();
}

std::unique_ptr<QuotaLedger> NewInMemoryQuotaLedger() { return std::make_unique<InMemoryQuotaLedger>(); }

absl::StatusOr<std::unique_ptr<QuotaLedger>> OpenSqliteQuotaLedger(const std::filesystem::path& data_dir) {
  auto db = OpenSqliteDatabase(data_dir / "tokens.sqlite3", kLedgerSchema);
  if (!db.ok()) return db.status();
  return std::unique_ptr<QuotaLedger>(new SqliteQuotaLedger(*db));
}

TokenQuotas::TokenQuotas(QuotaOptions options, std::function<int64_t()> now_ms, std::unique_ptr<QuotaLedger> ledger)
    : options_(options),
      now_ms_(std::move(now_ms)),
      ledger_(ledger != nullptr ? std::move(ledger) : NewInMemoryQuotaLedger()) {}

int64_t TokenQuotas::Now() const {
  if (now_ms_) return now_ms_();
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

absl::Status TokenQuotas::CheckSubmit(const std::string& token, int64_t pending) {
  if (pending >= options_.max_pending_jobs) {
    return WithErrorReason(absl::ResourceExhaustedError(absl::StrCat("pending jobs of token '", token, "': ", pending,
                                                                     " queued or running, the limit per token is ",
                                                                     options_.max_pending_jobs,
                                                                     "; retry once some finish")),
                           error_reason::kTokenPendingJobs);
  }
  return WindowLimit(token, "bakes", kHourMs, options_.max_bakes_per_hour,
                     absl::StrCat("bakes of token '", token, "': "), " in the last hour", " per hour; retry later",
                     error_reason::kTokenBakesPerHour);
}

void TokenQuotas::RecordBake(const std::string& token) { Record(token, "bakes", 1); }

absl::Status TokenQuotas::CheckUpload(const std::string& token) {
  return WindowLimit(token, "upload_bytes", kDayMs, options_.max_upload_bytes_per_day,
                     absl::StrCat("uploads of token '", token, "': "), " bytes in the last 24 hours", " bytes per day",
                     error_reason::kTokenUploadBytesPerDay);
}

void TokenQuotas::RecordUpload(const std::string& token, int64_t bytes) { Record(token, "upload_bytes", bytes); }

absl::Status TokenQuotas::WindowLimit(const std::string& token, std::string_view kind, int64_t window_ms,
                                      int64_t limit, const std::string& what, const char* span, const char* unit,
                                      std::string_view reason) {
  auto used = ledger_->Sum(token, kind, Now() - window_ms);
  if (!used.ok()) return used.status();
  if (*used < limit) return absl::OkStatus();
  return WithErrorReason(
      absl::ResourceExhaustedError(absl::StrCat(what, *used, span, ", the limit per token is ", limit, unit)), reason);
}

void TokenQuotas::Record(const std::string& token, std::string_view kind, int64_t amount) {
  const int64_t now = Now();
  if (auto s = ledger_->Record(token, kind, now, amount); !s.ok()) {
    spdlog::warn("event=quota_record_failed token=\"{}\" kind={} error=\"{}\"", token, kind, std::string(s.message()));
  }
  int64_t last = last_forget_ms_.load();
  if (now - last >= kForgetEveryMs && last_forget_ms_.compare_exchange_strong(last, now)) {
    if (auto s = ledger_->Forget(now - kDayMs); !s.ok()) {
      spdlog::warn("event=quota_forget_failed error=\"{}\"", std::string(s.message()));
    }
  }
}

}  // namespace impostor
