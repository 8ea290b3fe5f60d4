#include "server/store/token_store.h"

#include <openssl/rand.h>

#include <algorithm>
#include <array>
#include <cassert>
#include <cstdlib>
#include <mutex>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "common/request/worker_fit.h"
#include "common/util/sha256.h"
#include "server/store/sqlite/sqlite_open.h"

namespace impostor {
namespace {

constexpr char kBase64Url[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_";

constexpr const char* kSchema = R"sql(
PRAGMA journal_mode = WAL;
PRAGMA synchronous = FULL;
CREATE TABLE IF NOT EXISTS tokens (
  secret_hash  TEXT PRIMARY KEY,  -- lowercase hex SHA-256 of the token; the secret is never stored
  name         TEXT NOT NULL,
  role         TEXT NOT NULL,     -- reader, submitter, worker, admin
  created_ms   INTEGER NOT NULL,
  expires_ms   INTEGER NOT NULL DEFAULT 0,  -- 0 = never
  last_used_ms INTEGER NOT NULL DEFAULT 0,
  revoked_ms   INTEGER NOT NULL DEFAULT 0   -- 0 = live
);
CREATE UNIQUE INDEX IF NOT EXISTS tokens_live_name ON tokens (name) WHERE revoked_ms = 0;
)sql";

// Columns added after the first release, each with the statement that adds
// it to an older tokens.sqlite3 (existing rows get the default). Applied in
// order at open, each in its own write transaction so that a server and a
// `token` command opening one old file together add it once.
struct ColumnMigration {
  const char* column;
  const char* sql;
};
constexpr ColumnMigration kColumnMigrations[] = {
    // Issue 44: the token's default required tags, EncodeTokenRequiredTags.
    {"required_tags", "ALTER TABLE tokens ADD COLUMN required_tags TEXT NOT NULL DEFAULT ''"},
};

constexpr const char* kColumns =
    "secret_hash, name, role, created_ms, expires_ms, last_used_ms, revoked_ms, required_tags";

// Marks the live token named ?1 that expired by ?2 as revoked at its expiry.
constexpr const char* kRetireExpiredSql =
    "UPDATE tokens SET revoked_ms = expires_ms WHERE name = ?1 AND revoked_ms = 0 AND expires_ms > 0 AND "
    "expires_ms <= ?2";

// Every statement's errors name this store.
class Statement : public SqliteStatement {
 public:
  Statement(sqlite3* db, const char* sql) : SqliteStatement(db, sql, "token store") {}
};

absl::StatusOr<TokenRecord> ReadRecord(const Statement& st) {
  TokenRecord r;
  r.secret_hash = st.Text(0);
  r.name = st.Text(1);
  auto role = ParseRole(st.Text(2));
  if (!role.ok()) return absl::DataLossError(absl::StrCat("token '", r.name, "': stored role does not parse"));
  r.role = *role;
  r.created_ms = st.Int(3);
  r.expires_ms = st.Int(4);
  r.last_used_ms = st.Int(5);
  r.revoked_ms = st.Int(6);
  auto tags = DecodeTokenRequiredTags(st.Text(7), r.name);
  if (!tags.ok()) return tags.status();
  r.required_tags = *std::move(tags);
  return r;
}

// Adds the kColumnMigrations columns an older file lacks. INTERNAL naming
// the file and the column on failure.
absl::Status MigrateColumns(sqlite3* db, const std::filesystem::path& file) {
  for (const ColumnMigration& m : kColumnMigrations) {
    char* err = nullptr;
    auto exec = [&](const char* sql) -> absl::Status {
      if (sqlite3_exec(db, sql, nullptr, nullptr, &err) == SQLITE_OK) return absl::OkStatus();
      std::string msg = err ? err : "unknown error";
      sqlite3_free(err);
      sqlite3_exec(db, "ROLLBACK", nullptr, nullptr, nullptr);
      return absl::InternalError(absl::StrCat("cannot migrate ", file.string(), " (column ", m.column, "): ", msg));
    };
    if (auto s = exec("BEGIN IMMEDIATE"); !s.ok()) return s;
    bool present = false;
    {
      Statement has(db, "SELECT COUNT(*) FROM pragma_table_info('tokens') WHERE name = ?1");
      if (!has.ok()) {
        sqlite3_exec(db, "ROLLBACK", nullptr, nullptr, nullptr);
        return has.Error("prepare");
      }
      has.Bind(1, std::string(m.column));
      if (has.Step() != SQLITE_ROW) {
        absl::Status s = has.Error("read schema");
        sqlite3_exec(db, "ROLLBACK", nullptr, nullptr, nullptr);
        return s;
      }
      present = has.Int(0) > 0;
    }
    if (!present) {
      if (auto s = exec(m.sql); !s.ok()) return s;
    }
    if (auto s = exec("COMMIT"); !s.ok()) return s;
  }
  return absl::OkStatus();
}

class SqliteTokenStore final : public TokenStore {
 public:
  explicit SqliteTokenStore(sqlite3* db) : db_(db) {}
  ~SqliteTokenStore() override { sqlite3_close(db_); }

  absl::Status Insert(const TokenRecord& r) override {
    if (auto s = ValidateTokenRecord(r); !s.ok()) return s;
    std::lock_guard lock(mu_);
    {
      // An expired token no longer holds its name (TokenStore::Insert).
      Statement retire(db_, kRetireExpiredSql);
      if (!retire.ok()) return retire.Error("prepare");
      retire.Bind(1, r.name);
      retire.Bind(2, r.created_ms);
      if (retire.Step() != SQLITE_DONE) return retire.Error("retire expired");
    }
    Statement st(db_,
                 "INSERT INTO tokens (secret_hash, name, role, created_ms, expires_ms, required_tags) "
                 "VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
    if (!st.ok()) return st.Error("prepare");
    st.Bind(1, r.secret_hash);
    st.Bind(2, r.name);
    st.Bind(3, std::string(RoleName(r.role)));
    st.Bind(4, r.created_ms);
    st.Bind(5, r.expires_ms);
    st.Bind(6, EncodeTokenRequiredTags(r.required_tags));
    const int rc = st.Step();
    if (rc == SQLITE_CONSTRAINT) {
      return absl::AlreadyExistsError(
          absl::StrCat("--name: a live token named '", r.name, "' exists; revoke it first or pick another name"));
    }
    if (rc != SQLITE_DONE) return st.Error("insert");
    return absl::OkStatus();
  }

  absl::StatusOr<std::optional<TokenRecord>> FindByHash(const std::string& secret_hash) override {
    std::lock_guard lock(mu_);
    Statement st(db_, absl::StrCat("SELECT ", kColumns, " FROM tokens WHERE secret_hash = ?1").c_str());
    if (!st.ok()) return st.Error("prepare");
    st.Bind(1, secret_hash);
    const int rc = st.Step();
    if (rc == SQLITE_DONE) return std::optional<TokenRecord>();
    if (rc != SQLITE_ROW) return st.Error("query");
    auto r = ReadRecord(st);
    if (!r.ok()) return r.status();
    return std::optional<TokenRecord>(std::move(*r));
  }

  absl::StatusOr<std::vector<TokenRecord>> List() override {
    std::lock_guard lock(mu_);
    Statement st(db_, absl::StrCat("SELECT ", kColumns, " FROM tokens ORDER BY created_ms, name").c_str());
    if (!st.ok()) return st.Error("prepare");
    std::vector<TokenRecord> out;
    int rc;
    while ((rc = st.Step()) == SQLITE_ROW) {
      auto r = ReadRecord(st);
      if (!r.ok()) return r.status();
      out.push_back(std::move(*r));
    }
    if (rc != SQLITE_DONE) return st.Error("query");
    return out;
  }

  absl::Status Revoke(const std::string& name, int64_t now_ms) override {
    std::lock_guard lock(mu_);
    Statement st(db_, "UPDATE tokens SET revoked_ms = ?2 WHERE name = ?1 AND revoked_ms = 0");
    if (!st.ok()) return st.Error("prepare");
    st.Bind(1, name);
    st.Bind(2, std::max<int64_t>(now_ms, 1));
    if (st.Step() != SQLITE_DONE) return st.Error("revoke");
    if (sqlite3_changes(db_) == 0) return absl::NotFoundError(absl::StrCat("--name: no live token named '", name, "'"));
    return absl::OkStatus();
  }

  absl::Status MarkUsed(const std::string& secret_hash, int64_t now_ms) override {
    std::lock_guard lock(mu_);
    // MAX: the same rule as the PostgreSQL engine; last_used never moves back.
    Statement st(db_, "UPDATE tokens SET last_used_ms = MAX(last_used_ms, ?2) WHERE secret_hash = ?1");
    if (!st.ok()) return st.Error("prepare");
    st.Bind(1, secret_hash);
    st.Bind(2, now_ms);
    if (st.Step() != SQLITE_DONE) return st.Error("mark used");
    return absl::OkStatus();
  }

 private:
  std::mutex mu_;  // one connection, serialised
  sqlite3* const db_;
};

}  // namespace

std::string_view RoleName(Role role) {
  switch (role) {
    case Role::kReader:
      return "reader";
    case Role::kSubmitter:
      return "submitter";
    case Role::kWorker:
      return "worker";
    case Role::kAdmin:
      return "admin";
  }
  return "unknown";
}

absl::StatusOr<Role> ParseRole(std::string_view name) {
  for (Role r : {Role::kReader, Role::kSubmitter, Role::kWorker, Role::kAdmin}) {
    if (name == RoleName(r)) return r;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("--role: \"", std::string(name), "\" is not a role; expected reader, submitter, worker or admin"));
}

std::string NewTokenSecret() {
  std::array<unsigned char, 32> bytes;
  if (RAND_bytes(bytes.data(), static_cast<int>(bytes.size())) != 1) std::abort();  // no entropy: cannot go on safely
  std::string out(kTokenPrefix);
  uint32_t acc = 0;
  int bits = 0;
  for (unsigned char b : bytes) {
    acc = (acc << 8) | b;
    bits += 8;
    while (bits >= 6) {
      bits -= 6;
      out.push_back(kBase64Url[(acc >> bits) & 63]);
    }
  }
  if (bits > 0) out.push_back(kBase64Url[(acc << (6 - bits)) & 63]);
  return out;
}

bool IsWellFormedToken(std::string_view token) {
  if (token.size() != kTokenPrefix.size() + kTokenSecretChars || token.substr(0, kTokenPrefix.size()) != kTokenPrefix) {
    return false;
  }
  for (char c : token.substr(kTokenPrefix.size())) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' || c == '_';
    if (!ok) return false;
  }
  return true;
}

std::string TokenHash(std::string_view token) { return Sha256Hex(token); }

absl::Status ValidateTokenName(std::string_view name) {
  if (name.empty() || name.size() > 64) {
    return absl::InvalidArgumentError(absl::StrCat("--name: must be 1..64 characters, got ", name.size()));
  }
  for (char c : name) {
    const bool ok =
        (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' || c == '_' || c == '.';
    if (!ok) return absl::InvalidArgumentError("--name: only letters, digits, '.', '_' and '-' are allowed");
  }
  return absl::OkStatus();
}

absl::StatusOr<std::vector<std::string>> NormalizeTokenRequiredTags(const std::vector<std::string>& tags) {
  return NormalizeRequiredTagList(tags, "--require-tag", /*indexed=*/false);
}

absl::Status CheckRequiredTagsFitRole(Role role, const std::vector<std::string>& tags) {
  if (tags.empty() || role == Role::kSubmitter || role == Role::kAdmin) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat("--require-tag: a ", std::string(RoleName(role)),
                                                 " token submits no bakes; only submitter and admin tokens take "
                                                 "default required tags"));
}

std::string EncodeTokenRequiredTags(const std::vector<std::string>& tags) {
  auto normalized = NormalizeTokenRequiredTags(tags);
  assert(normalized.ok());  // ValidateTokenRecord ran first
  return absl::StrJoin(normalized.ok() ? *normalized : tags, ",");
}

absl::StatusOr<std::vector<std::string>> DecodeTokenRequiredTags(std::string_view column, std::string_view token_name) {
  std::vector<std::string> tags =
      absl::StrSplit(absl::string_view(column.data(), column.size()), ',', absl::SkipEmpty());
  auto normalized = NormalizeTokenRequiredTags(tags);
  if (!normalized.ok()) {
    return absl::DataLossError(absl::StrCat("token '", std::string(token_name),
                                            "': stored required tags do not parse: ", normalized.status().message()));
  }
  return normalized;
}

absl::Status ValidateTokenRecord(const TokenRecord& record) {
  if (auto s = ValidateTokenName(record.name); !s.ok()) return s;
  const int role = static_cast<int>(record.role);
  if (role < static_cast<int>(Role::kReader) || role > static_cast<int>(Role::kAdmin)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--role: ", role, " is not a role; expected reader, submitter, worker or admin"));
  }
  const bool hex = record.secret_hash.size() == 64 &&
                   record.secret_hash.find_first_not_of("0123456789abcdef") == std::string::npos;
  if (!hex) return absl::InvalidArgumentError("secret_hash: expected 64 lowercase hex digits (TokenHash)");
  if (auto tags = NormalizeTokenRequiredTags(record.required_tags); !tags.ok()) return tags.status();
  return CheckRequiredTagsFitRole(record.role, record.required_tags);
}

absl::StatusOr<std::unique_ptr<TokenStore>> OpenSqliteTokenStore(const std::filesystem::path& data_dir) {
  // `token create` and a running server share the file (WAL).
  const std::filesystem::path file = data_dir / "tokens.sqlite3";
  auto db = OpenSqliteDatabase(file, kSchema);
  if (!db.ok()) return db.status();
  if (auto s = MigrateColumns(*db, file); !s.ok()) {
    sqlite3_close(*db);
    return s;
  }
  return std::unique_ptr<TokenStore>(new SqliteTokenStore(*db));
}

}  // namespace impostor
