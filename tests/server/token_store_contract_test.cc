// The TokenStore and QuotaLedger contract on both engines (SQLite in a
// temporary directory, PostgreSQL on a real server this binary starts), and
// what sharing the PostgreSQL engine buys (issue 15): two replicas' stores
// on one database agree about tokens (added on one, honoured by the other;
// revoked on one, refused by the other once its Authenticator's cache TTL
// has passed, with a fake clock) and count a token's quota once. Also each
// engine's upgrade of a database from before default required tags.
#include <sqlite3.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "server/auth/authenticator.h"
#include "server/store/postgres/postgres_token_store.h"
#include "server/commands/token_command.h"
#include "server/store/token_quotas.h"
#include "server/store/token_store.h"
#include "server/store/token_store_factory.h"
#include "tests/server/job_store_test_engines.h"

namespace impostor::testing {
namespace {

struct SqliteTokens {
  static constexpr const char* kName = "sqlite";
  static absl::StatusOr<TokenStorage> Make() {
    static std::atomic<int> next{0};
    const auto dir = std::filesystem::temp_directory_path() /
                     ("token_store_contract_" + std::to_string(::getpid()) + "_" + std::to_string(next++));
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    return OpenTokenStorage({.data_dir = dir.string()});
  }
};

struct PostgresTokens {
  static constexpr const char* kName = "postgresql";
  static absl::StatusOr<TokenStorage> Make() {
    const std::string url = FreshPostgresDatabase();
    if (url.empty()) return absl::FailedPreconditionError("no PostgreSQL");
    return OpenTokenStorage({.database_url = url});
  }
};

// t00 .. t16: one tag over the limit.
std::vector<std::string> SeventeenTags() {
  std::vector<std::string> tags;
  for (int i = 0; i < 17; ++i) tags.push_back(absl::StrCat("t", i / 10, i % 10));
  return tags;
}

template <typename Engine>
class TokenStoreContract : public ::testing::Test {
 protected:
  void SetUp() override {
    auto opened = Engine::Make();
    ASSERT_TRUE(opened.ok()) << opened.status();
    storage_ = std::move(*opened);
  }
  TokenStore& tokens() { return *storage_.tokens; }
  QuotaLedger& ledger() { return *storage_.quotas; }

  TokenStorage storage_;
};

using Engines = ::testing::Types<SqliteTokens, PostgresTokens>;
TYPED_TEST_SUITE(TokenStoreContract, Engines, EngineNames);

TYPED_TEST(TokenStoreContract, InsertFindListRevokeAndReuseTheName) {
  TokenStore& store = this->tokens();
  const std::string secret = NewTokenSecret();
  const TokenRecord r{.name = "ci", .role = Role::kSubmitter, .secret_hash = TokenHash(secret), .created_ms = 1000,
                      .expires_ms = 5000};
  ASSERT_TRUE(store.Insert(r).ok());
  TokenRecord twin = r;
  twin.secret_hash = TokenHash(NewTokenSecret());
  const absl::Status taken = store.Insert(twin);
  EXPECT_EQ(taken.code(), absl::StatusCode::kAlreadyExists) << taken;
  EXPECT_NE(taken.message().find("--name: a live token named 'ci' exists"), std::string::npos) << taken;

  auto found = store.FindByHash(TokenHash(secret));
  ASSERT_TRUE(found.ok() && found->has_value()) << found.status();
  EXPECT_EQ((*found)->name, "ci");
  EXPECT_EQ((*found)->role, Role::kSubmitter);
  EXPECT_EQ((*found)->created_ms, 1000);
  EXPECT_EQ((*found)->expires_ms, 5000);
  EXPECT_EQ((*found)->revoked_ms, 0);
  auto missing = store.FindByHash(TokenHash(NewTokenSecret()));
  ASSERT_TRUE(missing.ok());
  EXPECT_FALSE(missing->has_value());

  EXPECT_EQ(store.Revoke("nobody", 2000).code(), absl::StatusCode::kNotFound);
  ASSERT_TRUE(store.Revoke("ci", 2000).ok());
  EXPECT_EQ(store.Revoke("ci", 2001).code(), absl::StatusCode::kNotFound);
  ASSERT_TRUE(store.Insert(twin).ok()) << "revoking frees the name for a successor";
  auto all = store.List();
  ASSERT_TRUE(all.ok()) << all.status();
  ASSERT_EQ(all->size(), 2u);
  EXPECT_EQ((*all)[0].revoked_ms, 2000);
  EXPECT_EQ((*all)[1].revoked_ms, 0);
  EXPECT_EQ((*all)[1].secret_hash, twin.secret_hash);
}

TYPED_TEST(TokenStoreContract, AnExpiredTokenGivesUpItsNameAndStaysDead) {
  TokenStore& store = this->tokens();
  const std::string old_secret = NewTokenSecret();
  ASSERT_TRUE(store
                  .Insert({.name = "ci", .role = Role::kSubmitter, .secret_hash = TokenHash(old_secret),
                           .created_ms = 1000, .expires_ms = 5000})
                  .ok());
  const TokenRecord renewed{.name = "ci", .role = Role::kSubmitter, .secret_hash = TokenHash(NewTokenSecret()),
                            .created_ms = 5000, .expires_ms = 9000};
  ASSERT_TRUE(store.Insert(renewed).ok()) << "the old one expired at 5000";
  auto old = store.FindByHash(TokenHash(old_secret));
  ASSERT_TRUE(old.ok() && old->has_value()) << old.status();
  EXPECT_EQ((*old)->revoked_ms, 5000) << "ended at its expiry";
  // The successor is live and holds the name until it expires too.
  TokenRecord third = renewed;
  third.secret_hash = TokenHash(NewTokenSecret());
  third.created_ms = 8999;
  EXPECT_EQ(store.Insert(third).code(), absl::StatusCode::kAlreadyExists);
  // A token that never expires keeps its name.
  ASSERT_TRUE(store
                  .Insert({.name = "forever", .role = Role::kReader, .secret_hash = TokenHash(NewTokenSecret()),
                           .created_ms = 1000})
                  .ok());
  EXPECT_EQ(store
                .Insert({.name = "forever", .role = Role::kReader, .secret_hash = TokenHash(NewTokenSecret()),
                         .created_ms = 1'000'000'000})
                .code(),
            absl::StatusCode::kAlreadyExists);
}

TYPED_TEST(TokenStoreContract, EveryRoleRoundTripsAndLastUsedNeverMovesBack) {
  TokenStore& store = this->tokens();
  for (Role role : {Role::kReader, Role::kSubmitter, Role::kWorker, Role::kAdmin}) {
    const std::string hash = TokenHash(NewTokenSecret());
    const std::string name = "t-" + std::string(RoleName(role));
    ASSERT_TRUE(store.Insert({.name = name, .role = role, .secret_hash = hash, .created_ms = 1}).ok()) << name;
    auto found = store.FindByHash(hash);
    ASSERT_TRUE(found.ok() && found->has_value()) << name;
    EXPECT_EQ((*found)->role, role) << name;
  }
  const std::string hash = TokenHash(NewTokenSecret());
  ASSERT_TRUE(store.Insert({.name = "used", .role = Role::kReader, .secret_hash = hash, .created_ms = 1}).ok());
  ASSERT_TRUE(store.MarkUsed(hash, 5000).ok());
  ASSERT_TRUE(store.MarkUsed(hash, 4000).ok());  // a replica whose clock is behind
  auto found = store.FindByHash(hash);
  ASSERT_TRUE(found.ok() && found->has_value());
  EXPECT_EQ((*found)->last_used_ms, 5000);
}

// A token's default required tags (issue 44) come back sorted without
// repeats from FindByHash and List; a token without any has none; 16
// distinct tags (the limit) fit.
TYPED_TEST(TokenStoreContract, RequiredTagsComeBackSortedWithoutRepeats) {
  TokenStore& store = this->tokens();
  const std::string forest = TokenHash(NewTokenSecret());
  ASSERT_TRUE(store
                  .Insert({.name = "forest-ci", .role = Role::kSubmitter, .secret_hash = forest, .created_ms = 1,
                           .required_tags = {"team-forest", "gpu", "team-forest"}})
                  .ok());
  const std::string plain = TokenHash(NewTokenSecret());
  ASSERT_TRUE(store.Insert({.name = "plain", .role = Role::kSubmitter, .secret_hash = plain, .created_ms = 2}).ok());
  std::vector<std::string> sixteen = SeventeenTags();
  sixteen.pop_back();
  const std::string wide = TokenHash(NewTokenSecret());
  ASSERT_TRUE(store
                  .Insert({.name = "wide", .role = Role::kAdmin, .secret_hash = wide, .created_ms = 3,
                           .required_tags = sixteen})
                  .ok());

  auto found = store.FindByHash(forest);
  ASSERT_TRUE(found.ok() && found->has_value()) << found.status();
  EXPECT_EQ((*found)->required_tags, (std::vector<std::string>{"gpu", "team-forest"}));
  auto none = store.FindByHash(plain);
  ASSERT_TRUE(none.ok() && none->has_value()) << none.status();
  EXPECT_TRUE((*none)->required_tags.empty());
  auto all = store.List();
  ASSERT_TRUE(all.ok()) << all.status();
  ASSERT_EQ(all->size(), 3u);
  EXPECT_EQ((*all)[0].required_tags, (std::vector<std::string>{"gpu", "team-forest"}));
  EXPECT_TRUE((*all)[1].required_tags.empty());
  std::sort(sixteen.begin(), sixteen.end());
  EXPECT_EQ((*all)[2].required_tags, sixteen);
}

TYPED_TEST(TokenStoreContract, BadRecordsAreRefusedNamingTheFieldAndNothingIsStored) {
  const std::string hash = TokenHash(NewTokenSecret());
  struct Case {
    const char* name;
    TokenRecord record;
    const char* expected;
  } cases[] = {
      {"empty name", {.name = "", .secret_hash = hash}, "--name: must be 1..64 characters, got 0"},
      {"too-long name", {.name = std::string(65, 'a'), .secret_hash = hash}, "--name: must be 1..64 characters, got 65"},
      {"space in name", {.name = "a b", .secret_hash = hash}, "--name: only letters, digits"},
      {"quote in name", {.name = "x'; DROP TABLE tokens; --", .secret_hash = hash}, "--name: only letters, digits"},
      {"unknown role", {.name = "r", .role = static_cast<Role>(7), .secret_hash = hash},
       "--role: 7 is not a role; expected reader, submitter, worker or admin"},
      {"negative role", {.name = "r", .role = static_cast<Role>(-1), .secret_hash = hash}, "--role: -1 is not a role"},
      {"secret instead of hash", {.name = "s", .secret_hash = NewTokenSecret()}, "secret_hash: expected 64"},
      {"upper-case hash", {.name = "s", .secret_hash = std::string(64, 'A')}, "secret_hash: expected 64"},
      {"upper-case tag",
       {.name = "t", .role = Role::kSubmitter, .secret_hash = hash, .required_tags = {"gpu", "GPU"}},
       "--require-tag: \"GPU\" is not 1..64 bytes of [a-z0-9._-]"},
      {"empty tag", {.name = "t", .role = Role::kSubmitter, .secret_hash = hash, .required_tags = {""}},
       "--require-tag: \"\" is not 1..64 bytes"},
      {"65-byte tag",
       {.name = "t", .role = Role::kSubmitter, .secret_hash = hash, .required_tags = {std::string(65, 'a')}},
       "is not 1..64 bytes"},
      {"comma in tag", {.name = "t", .role = Role::kAdmin, .secret_hash = hash, .required_tags = {"gpu,cpu"}},
       "--require-tag: \"gpu,cpu\" is not"},
      {"17 tags", {.name = "t", .role = Role::kSubmitter, .secret_hash = hash, .required_tags = SeventeenTags()},
       "--require-tag: 17 tags is over the limit of 16"},
      {"tags on a worker token", {.name = "w", .role = Role::kWorker, .secret_hash = hash, .required_tags = {"gpu"}},
       "--require-tag: a worker token submits no bakes"},
      {"tags on a reader token", {.name = "r", .role = Role::kReader, .secret_hash = hash, .required_tags = {"gpu"}},
       "--require-tag: a reader token submits no bakes"},
  };
  for (const Case& c : cases) {
    const absl::Status s = this->tokens().Insert(c.record);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << c.name << ": " << s;
    EXPECT_NE(s.message().find(c.expected), std::string::npos) << c.name << ": " << s;
  }
  auto all = this->tokens().List();
  ASSERT_TRUE(all.ok());
  EXPECT_TRUE(all->empty()) << all->size() << " records stored";
}

TYPED_TEST(TokenStoreContract, LedgerSumsPerTokenAndKindInsideTheWindowAndForgets) {
  QuotaLedger& ledger = this->ledger();
  ASSERT_TRUE(ledger.Record("ci", "bakes", 1000, 1).ok());
  ASSERT_TRUE(ledger.Record("ci", "bakes", 2000, 1).ok());
  ASSERT_TRUE(ledger.Record("ci", "upload_bytes", 2000, 700).ok());
  ASSERT_TRUE(ledger.Record("other", "bakes", 2000, 5).ok());
  struct Case {
    const char* token;
    const char* kind;
    int64_t after_ms;
    int64_t sum;
  } cases[] = {
      {"ci", "bakes", 0, 2},       {"ci", "bakes", 999, 2},   {"ci", "bakes", 1000, 1},
      {"ci", "bakes", 2000, 0},    {"ci", "upload_bytes", 0, 700}, {"other", "bakes", 0, 5},
      {"nobody", "bakes", 0, 0},
  };
  for (const Case& c : cases) {
    auto sum = ledger.Sum(c.token, c.kind, c.after_ms);
    ASSERT_TRUE(sum.ok()) << sum.status();
    EXPECT_EQ(*sum, c.sum) << c.token << " " << c.kind << " after " << c.after_ms;
  }
  ASSERT_TRUE(ledger.Forget(1000).ok());
  auto sum = ledger.Sum("ci", "bakes", 0);
  ASSERT_TRUE(sum.ok());
  EXPECT_EQ(*sum, 1) << "the event at 1000 is forgotten, the one at 2000 kept";
}

TYPED_TEST(TokenStoreContract, BadLedgerEventsAreRefusedNamingTheField) {
  struct Case {
    const char* name;
    std::string token;
    std::string kind;
    int64_t amount;
    const char* expected;
  } cases[] = {
      {"empty token", "", "bakes", 1, "quota token: --name: must be 1..64"},
      {"too-long token", std::string(65, 't'), "bakes", 1, "quota token: --name: must be 1..64"},
      {"unknown kind", "ci", "gpus", 1, "quota kind: \"gpus\" is not bakes or upload_bytes"},
      {"negative amount", "ci", "upload_bytes", -5, "quota amount: -5 is negative"},
  };
  for (const Case& c : cases) {
    const absl::Status s = this->ledger().Record(c.token, c.kind, 1000, c.amount);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << c.name << ": " << s;
    EXPECT_NE(s.message().find(c.expected), std::string::npos) << c.name << ": " << s;
  }
  auto sum = this->ledger().Sum("ci", "upload_bytes", 0);
  ASSERT_TRUE(sum.ok());
  EXPECT_EQ(*sum, 0);
}

// Two replicas: each opens its own storage on one database, as two
// impostor-server processes with the same --database do.
class SharedTokens : public ::testing::Test {
 protected:
  void SetUp() override {
    url_ = FreshPostgresDatabase();
    ASSERT_FALSE(url_.empty());
    for (auto& r : replicas_) {
      auto opened = OpenTokenStorage({.database_url = url_});
      ASSERT_TRUE(opened.ok()) << opened.status();
      r = std::move(*opened);
    }
  }
  std::string Add(int replica, const std::string& name, Role role) {
    const std::string secret = NewTokenSecret();
    EXPECT_TRUE(replicas_[replica]
                    .tokens->Insert({.name = name, .role = role, .secret_hash = TokenHash(secret), .created_ms = now_})
                    .ok());
    return secret;
  }
  static absl::StatusOr<Principal> Call(Authenticator& a, const std::string& secret) {
    const std::string header = "Bearer " + secret;
    return a.Authenticate(&header);
  }

  std::string url_;
  TokenStorage replicas_[2];
  int64_t now_ = 1'700'000'000'000;
};

TEST_F(SharedTokens, AddedOnOneReplicaIsHonouredOnTheOther) {
  Authenticator b(replicas_[1].tokens.get(), 2000, [this] { return now_; });
  // B has never seen it (and an unknown token is not cached): accepted at once.
  const std::string secret = Add(0, "artist", Role::kSubmitter);
  auto p = Call(b, secret);
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(p->name, "artist");
  EXPECT_EQ(p->role, Role::kSubmitter);
  // B's use is visible through A.
  auto listed = replicas_[0].tokens->List();
  ASSERT_TRUE(listed.ok());
  ASSERT_EQ(listed->size(), 1u);
  EXPECT_EQ((*listed)[0].last_used_ms, now_);
  // One live name across replicas: B cannot add a second "artist".
  EXPECT_EQ(replicas_[1]
                .tokens->Insert({.name = "artist", .role = Role::kAdmin, .secret_hash = TokenHash(NewTokenSecret())})
                .code(),
            absl::StatusCode::kAlreadyExists);
}

// The revocation delay is B's cache TTL: at TTL - 1 ms B still answers from
// its cache, at TTL it reads the database and refuses. With TTL 0
// (--token-cache-ttl-ms=0) the refusal is immediate.
TEST_F(SharedTokens, RevokedOnOneReplicaIsRefusedOnTheOtherOnceTheTtlPasses) {
  Authenticator b(replicas_[1].tokens.get(), 2000, [this] { return now_; });
  Authenticator b_uncached(replicas_[1].tokens.get(), 0, [this] { return now_; });
  const std::string secret = Add(0, "worker-7", Role::kWorker);
  ASSERT_TRUE(Call(b, secret).ok());
  ASSERT_TRUE(Call(b_uncached, secret).ok());
  ASSERT_TRUE(replicas_[0].tokens->Revoke("worker-7", now_).ok());

  auto p = Call(b_uncached, secret);
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.status().code(), absl::StatusCode::kUnauthenticated);
  EXPECT_NE(p.status().message().find("revoked token: 'worker-7'"), std::string::npos) << p.status();
  now_ += 1999;
  EXPECT_TRUE(Call(b, secret).ok()) << "still inside B's 2 s cache";
  now_ += 1;
  p = Call(b, secret);
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.status().code(), absl::StatusCode::kUnauthenticated);
  EXPECT_NE(p.status().message().find("revoked token: 'worker-7'"), std::string::npos) << p.status();
}

TEST_F(SharedTokens, AQuotaSpentOnBothReplicasIsCountedOnce) {
  const QuotaOptions options{.max_pending_jobs = 100, .max_upload_bytes_per_day = 1000, .max_bakes_per_hour = 3};
  TokenQuotas a(options, [this] { return now_; }, std::move(replicas_[0].quotas));
  TokenQuotas b(options, [this] { return now_; }, std::move(replicas_[1].quotas));
  a.RecordBake("ci");
  b.RecordBake("ci");
  EXPECT_TRUE(a.CheckSubmit("ci", 0).ok());
  a.RecordBake("ci");
  for (TokenQuotas* q : {&a, &b}) {
    const absl::Status s = q->CheckSubmit("ci", 0);
    EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted) << s;
    EXPECT_NE(s.message().find("bakes of token 'ci': 3 in the last hour, the limit per token is 3"),
              std::string::npos)
        << s;
  }
  a.RecordUpload("ci", 600);
  EXPECT_TRUE(b.CheckUpload("ci").ok());
  b.RecordUpload("ci", 400);
  const absl::Status s = a.CheckUpload("ci");
  EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted) << s;
  EXPECT_NE(s.message().find("1000 bytes in the last 24 hours"), std::string::npos) << s;
  now_ += 3'600'000;
  EXPECT_TRUE(b.CheckSubmit("ci", 0).ok()) << "the hour has passed on every replica";
}

// The token tables are versioned on their own (token_schema_version), beside
// the job store's: both open on one database in either order, and a token
// schema newer than the binary is refused naming the URL without a password.
TEST(PostgresTokenSchema, BesideTheJobStoreAndNewerIsRefused) {
  const std::string url = FreshPostgresDatabase();
  ASSERT_FALSE(url.empty());
  auto tokens = OpenTokenStorage({.database_url = url});
  ASSERT_TRUE(tokens.ok()) << tokens.status();
  auto jobs = PostgresJobStore::Open({.url = url, .pool_size = 2});
  ASSERT_TRUE(jobs.ok()) << jobs.status();
  const std::string db = DatabaseName(url);
  auto versions = SharedPostgres()->Query(
      db, "SELECT (SELECT version FROM schema_version) || ',' || (SELECT version FROM token_schema_version)");
  ASSERT_TRUE(versions.ok()) << versions.status();
  EXPECT_EQ(*versions, absl::StrCat(PostgresSchemaVersion(), ",", PostgresTokenSchemaVersion(), "\n"));

  ASSERT_TRUE(SharedPostgres()->Query(db, "UPDATE token_schema_version SET version = 99").ok());
  auto again = OpenTokenStorage({.database_url = url});
  ASSERT_FALSE(again.ok());
  EXPECT_EQ(again.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(again.status().message().find("token store schema version 99 is newer"), std::string::npos)
      << again.status();
  EXPECT_TRUE(PostgresJobStore::Open({.url = url, .pool_size = 2}).ok()) << "the job store's version is its own";
}

// A database from before default required tags (issue 44) upgrades at
// open: its tokens keep working with no tags, and new tokens take tags.
// PostgreSQL: token schema version 1 (no required_tags column) to the
// current one.
TEST(PostgresTokenSchema, Version1GainsRequiredTagsAndKeepsItsTokens) {
  const std::string url = FreshPostgresDatabase();
  ASSERT_FALSE(url.empty());
  ASSERT_TRUE(OpenTokenStorage({.database_url = url}).ok());
  const std::string db = DatabaseName(url);
  const std::string old_hash = TokenHash(NewTokenSecret());
  auto downgraded = SharedPostgres()->Query(
      db, absl::StrCat("ALTER TABLE tokens DROP COLUMN required_tags; UPDATE token_schema_version SET version = 1; "
                       "INSERT INTO tokens (secret_hash, name, role, created_ms) VALUES ('",
                       old_hash, "', 'old-ci', 'submitter', 1000)"));
  ASSERT_TRUE(downgraded.ok()) << downgraded.status();

  auto reopened = OpenTokenStorage({.database_url = url});
  ASSERT_TRUE(reopened.ok()) << reopened.status();
  auto version = SharedPostgres()->Query(db, "SELECT version FROM token_schema_version");
  ASSERT_TRUE(version.ok()) << version.status();
  EXPECT_EQ(*version, absl::StrCat(PostgresTokenSchemaVersion(), "\n"));
  EXPECT_GE(PostgresTokenSchemaVersion(), 2);
  auto old = reopened->tokens->FindByHash(old_hash);
  ASSERT_TRUE(old.ok() && old->has_value()) << old.status();
  EXPECT_EQ((*old)->name, "old-ci");
  EXPECT_TRUE((*old)->required_tags.empty());
  const std::string new_hash = TokenHash(NewTokenSecret());
  ASSERT_TRUE(reopened->tokens
                  ->Insert({.name = "forest-ci", .role = Role::kSubmitter, .secret_hash = new_hash,
                            .created_ms = 2000, .required_tags = {"team-forest"}})
                  .ok());
  auto tagged = reopened->tokens->FindByHash(new_hash);
  ASSERT_TRUE(tagged.ok() && tagged->has_value()) << tagged.status();
  EXPECT_EQ((*tagged)->required_tags, (std::vector<std::string>{"team-forest"}));
}

// SQLite: a tokens.sqlite3 as the first release wrote it (no required_tags
// column), opened twice (the second open finds the column).
TEST(SqliteTokenSchema, AnOlderFileGainsRequiredTagsAndKeepsItsTokens) {
  const auto dir = std::filesystem::temp_directory_path() / ("token_store_old_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string old_hash = TokenHash(NewTokenSecret());
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((dir / "tokens.sqlite3").c_str(), &db), SQLITE_OK);
    const std::string sql = absl::StrCat(
        "CREATE TABLE tokens (secret_hash TEXT PRIMARY KEY, name TEXT NOT NULL, role TEXT NOT NULL, "
        "created_ms INTEGER NOT NULL, expires_ms INTEGER NOT NULL DEFAULT 0, last_used_ms INTEGER NOT NULL DEFAULT 0, "
        "revoked_ms INTEGER NOT NULL DEFAULT 0);"
        "CREATE UNIQUE INDEX tokens_live_name ON tokens (name) WHERE revoked_ms = 0;"
        "INSERT INTO tokens (secret_hash, name, role, created_ms) VALUES ('",
        old_hash, "', 'old-ci', 'submitter', 1000);");
    char* err = nullptr;
    const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err);
    const std::string message = err ? err : "";
    sqlite3_free(err);
    sqlite3_close(db);
    ASSERT_EQ(rc, SQLITE_OK) << message;
  }
  const std::string new_hash = TokenHash(NewTokenSecret());
  {
    auto opened = OpenTokenStorage({.data_dir = dir.string()});
    ASSERT_TRUE(opened.ok()) << opened.status();
    auto old = opened->tokens->FindByHash(old_hash);
    ASSERT_TRUE(old.ok() && old->has_value()) << old.status();
    EXPECT_EQ((*old)->name, "old-ci");
    EXPECT_TRUE((*old)->required_tags.empty());
    ASSERT_TRUE(opened->tokens
                    ->Insert({.name = "forest-ci", .role = Role::kSubmitter, .secret_hash = new_hash,
                              .created_ms = 2000, .required_tags = {"team-forest"}})
                    .ok());
  }
  auto again = OpenTokenStorage({.data_dir = dir.string()});
  ASSERT_TRUE(again.ok()) << again.status();
  auto tagged = again->tokens->FindByHash(new_hash);
  ASSERT_TRUE(tagged.ok() && tagged->has_value()) << tagged.status();
  EXPECT_EQ((*tagged)->required_tags, (std::vector<std::string>{"team-forest"}));
  auto all = again->tokens->List();
  ASSERT_TRUE(all.ok()) << all.status();
  EXPECT_EQ(all->size(), 2u);
}

TEST(TokenStoreFactory, BadUrlsNameTheFlagAndHideThePassword) {
  auto other = OpenTokenStorage({.database_url = "mysql://u:hunter2@db/farm"});
  ASSERT_FALSE(other.ok());
  EXPECT_EQ(other.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(other.status().message().find("--database: expected a postgresql:// or postgres:// URL, got \"mysql:"),
            std::string::npos)
      << other.status();
  EXPECT_EQ(other.status().message().find("hunter2"), std::string::npos);
  auto none = OpenTokenStorage({});
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.status().message().find("--data: required"), std::string::npos) << none.status();
  auto unreachable =
      OpenTokenStorage({.database_url = "postgresql://farm:hunter2@127.0.0.1:1/jobs?connect_timeout=2"});
  ASSERT_FALSE(unreachable.ok());
  EXPECT_EQ(unreachable.status().code(), absl::StatusCode::kUnavailable) << unreachable.status();
  EXPECT_NE(unreachable.status().message().find("postgresql://farm:***@127.0.0.1:1/jobs"), std::string::npos)
      << unreachable.status();
  EXPECT_EQ(unreachable.status().message().find("hunter2"), std::string::npos);
}

// Replicas on one database each mint a token for their --local-workers:
// the names must differ per replica (one replica's restart revokes only its
// own), stay stable across restarts, and be valid token names.
TEST(LocalWorkerTokenName, OnePerReplicaOnASharedDatabase) {
  EXPECT_EQ(LocalWorkerTokenName(false, "/srv/a"), "local-workers");
  const std::string a = LocalWorkerTokenName(true, "/srv/a");
  const std::string b = LocalWorkerTokenName(true, "/srv/b");
  EXPECT_NE(a, b);
  EXPECT_EQ(a, LocalWorkerTokenName(true, "/srv/a"));
  EXPECT_EQ(a.rfind("local-workers-", 0), 0u) << a;
  EXPECT_TRUE(ValidateTokenName(a).ok()) << a;
}

}  // namespace
}  // namespace impostor::testing
