#include "server/store/postgres/postgres_token_store.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "server/store/postgres/pg_connection_pool.h"
#include "server/store/postgres/pg_migrations.h"

namespace impostor {
namespace {

constexpr int64_t kTokenReconnectWindowMs = 3000;

// Token schema migrations, version = index + 1; never edit a released one.
constexpr const char* kMigrations[] = {
    // 1 (issue 15): SQLite's tokens.sqlite3 tables in PostgreSQL types.
    R"sql(
CREATE TABLE tokens (
  secret_hash  TEXT PRIMARY KEY,  -- lowercase hex SHA-256 of the token; the secret is never stored
  name         TEXT NOT NULL,
  role         TEXT NOT NULL CHECK (role IN ('reader', 'submitter', 'worker', 'admin')),
  created_ms   BIGINT NOT NULL,
  expires_ms   BIGINT NOT NULL DEFAULT 0,  -- 0 = never
  last_used_ms BIGINT NOT NULL DEFAULT 0,
  revoked_ms   BIGINT NOT NULL DEFAULT 0   -- 0 = live
);
CREATE UNIQUE INDEX tokens_live_name ON tokens (name) WHERE revoked_ms = 0;
CREATE TABLE quota_events (
  token  TEXT NOT NULL,    -- token name
  kind   TEXT NOT NULL,    -- bakes, upload_bytes
  at_ms  BIGINT NOT NULL,  -- Unix ms
  amount BIGINT NOT NULL
);
CREATE INDEX quota_events_window ON quota_events (token, kind, at_ms);
CREATE INDEX quota_events_age ON quota_events (at_ms);
)sql",
    // 2 (issue 44): the token's default required tags, EncodeTokenRequiredTags.
    "ALTER TABLE tokens ADD COLUMN required_tags TEXT NOT NULL DEFAULT ''",
};

constexpr const char* kColumns =
    "secret_hash, name, role, created_ms, expires_ms, last_used_ms, revoked_ms, required_tags";

absl::StatusOr<TokenRecord> ReadRecord(const PgRows& rows, int i) {
  TokenRecord r;
  r.secret_hash = rows.Text(i, 0);
  r.name = rows.Text(i, 1);
  auto role = ParseRole(rows.Text(i, 2));
  if (!role.ok()) return absl::DataLossError(absl::StrCat("token '", r.name, "': stored role does not parse"));
  r.role = *role;
  r.created_ms = rows.Int(i, 3);
  r.expires_ms = rows.Int(i, 4);
  r.last_used_ms = rows.Int(i, 5);
  r.revoked_ms = rows.Int(i, 6);
  auto tags = DecodeTokenRequiredTags(rows.Text(i, 7), r.name);
  if (!tags.ok()) return tags.status();
  r.required_tags = *std::move(tags);
  return r;
}

class PostgresTokenStore final : public TokenStore {
 public:
  explicit PostgresTokenStore(std::shared_ptr<PgConnectionPool> pool) : pool_(std::move(pool)) {}

  absl::Status Insert(const TokenRecord& r) override {
    if (auto s = ValidateTokenRecord(r); !s.ok()) return s;
    // An expired token no longer holds its name (TokenStore::Insert).
    auto retired = pool_->Exec("retire expired token",
                               "UPDATE tokens SET revoked_ms = expires_ms WHERE name = $1 AND revoked_ms = 0 AND "
                               "expires_ms > 0 AND expires_ms <= $2",
                               PgParams().Text(r.name).Int(r.created_ms));
    if (!retired.ok()) return retired.status();
    auto rows = pool_->Exec("insert token",
                            "INSERT INTO tokens (secret_hash, name, role, created_ms, expires_ms, required_tags) "
                            "VALUES ($1, $2, $3, $4, $5, $6)",
                            PgParams()
                                .Text(r.secret_hash)
                                .Text(r.name)
                                .Text(std::string(RoleName(r.role)))
                                .Int(r.created_ms)
                                .Int(r.expires_ms)
                                .Text(EncodeTokenRequiredTags(r.required_tags)));
    if (absl::IsAlreadyExists(rows.status())) {
      return absl::AlreadyExistsError(
          absl::StrCat("--name: a live token named '", r.name, "' exists; revoke it first or pick another name"));
    }
    return rows.status();
  }

  absl::StatusOr<std::optional<TokenRecord>> FindByHash(const std::string& secret_hash) override {
    auto rows = pool_->Exec("find token", absl::StrCat("SELECT ", kColumns, " FROM tokens WHERE secret_hash = $1"),
                            PgParams().Text(secret_hash));
    if (!rows.ok()) return rows.status();
    if (rows->size() == 0) return std::optional<TokenRecord>();
    auto r = ReadRecord(*rows, 0);
    if (!r.ok()) return r.status();
    return std::optional<TokenRecord>(std::move(*r));
  }

  absl::StatusOr<std::vector<TokenRecord>> List() override {
    return ReadEachRow<TokenRecord>(
        pool_->Exec("list tokens", absl::StrCat("SELECT ", kColumns, " FROM tokens ORDER BY created_ms, name")),
        ReadRecord);
  }

  absl::Status Revoke(const std::string& name, int64_t now_ms) override {
    auto rows = pool_->Exec("revoke token", "UPDATE tokens SET revoked_ms = $2 WHERE name = $1 AND revoked_ms = 0",
                            PgParams().Text(name).Int(std::max<int64_t>(now_ms, 1)));
    if (!rows.ok()) return rows.status();
    if (rows->changed() == 0) return absl::NotFoundError(absl::StrCat("--name: no live token named '", name, "'"));
    return absl::OkStatus();
  }

  absl::Status MarkUsed(const std::string& secret_hash, int64_t now_ms) override {
    // GREATEST: replicas with clocks a little apart never move it back.
    return pool_
        ->Exec("mark token used",
               "UPDATE tokens SET last_used_ms = GREATEST(last_used_ms, $2) WHERE secret_hash = $1",
               PgParams().Text(secret_hash).Int(now_ms))
        .status();
  }

 private:
  const std::shared_ptr<PgConnectionPool> pool_;
};

class PostgresQuotaLedger final : public QuotaLedger {
 public:
  explicit PostgresQuotaLedger(std::shared_ptr<PgConnectionPool> pool) : pool_(std::move(pool)) {}

  absl::Status Record(const std::string& token, std::string_view kind, int64_t at_ms, int64_t amount) override {
    if (auto s = ValidateQuotaEvent(token, kind, amount); !s.ok()) return s;
    return pool_
        ->Exec("record quota event", "INSERT INTO quota_events (token, kind, at_ms, amount) VALUES ($1, $2, $3, $4)",
               PgParams().Text(token).Text(std::string(kind)).Int(at_ms).Int(amount))
        .status();
  }
  absl::StatusOr<int64_t> Sum(const std::string& token, std::string_view kind, int64_t after_ms) override {
    auto rows = pool_->Exec(
        "sum quota events",
        "SELECT COALESCE(SUM(amount), 0) FROM quota_events WHERE token = $1 AND kind = $2 AND at_ms > $3",
        PgParams().Text(token).Text(std::string(kind)).Int(after_ms));
    if (!rows.ok()) return rows.status();
    return rows->Int(0, 0);
  }
  absl::Status Forget(int64_t up_to_ms) override {
    return pool_->Exec("forget quota events", "DELETE FROM quota_events WHERE at_ms <= $1", PgParams().Int(up_to_ms))
        .status();
  }

 private:
  const std::shared_ptr<PgConnectionPool> pool_;
};

}  // namespace

int PostgresTokenSchemaVersion() { return static_cast<int>(std::size(kMigrations)); }

absl::StatusOr<PostgresTokenStorage> OpenPostgresTokenStorage(const PostgresTokenOptions& options) {
  // A token check waits for a database restart a few seconds, not the job
  // store's 30: every call behind it is a caller kept waiting (answered
  // UNAVAILABLE / HTTP 503 after that, never "bad token").
  auto opened = PgConnectionPool::Open(
      {.url = options.url,
       .size = options.pool_size,
       .statement_timeout_ms = options.statement_timeout_ms,
       .reconnect_window_ms = kTokenReconnectWindowMs,
       .dead_link_seconds = options.dead_link_seconds});
  if (!opened.ok()) return opened.status();
  std::shared_ptr<PgConnectionPool> pool = std::move(*opened);
  if (auto s = ApplyPgMigrations(
          *pool, {.component = "token store", .version_table = "token_schema_version", .scripts = kMigrations});
      !s.ok()) {
    return s;
  }
  return PostgresTokenStorage{.tokens = std::make_unique<PostgresTokenStore>(pool),
                              .quotas = std::make_unique<PostgresQuotaLedger>(pool)};
}

}  // namespace impostor
