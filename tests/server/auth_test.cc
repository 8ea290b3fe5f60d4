// Identity and roles (issue 14), in process: the token store on a real
// SQLite file, the authenticator with a fake clock (expiry, revocation seen
// after the TTL), the role table, --auth and --expires-in parsing, the
// clients' token sources, the quota windows, and the job database's
// migration from before tokens.
#include <sqlite3.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/error_reason.h"
#include "common/net/token_source.h"
#include "server/auth/access_policy.h"
#include "server/auth/auth_mode.h"
#include "server/auth/authenticator.h"
#include "server/store/job_store.h"
#include "server/commands/token_command.h"
#include "server/rpc/submit_tags.h"
#include "server/store/token_quotas.h"
#include "server/store/token_store.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

fs::path TempDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("impostor_auth_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

TEST(TokenSecret, HasTheDocumentedShapeAndIsFresh) {
  std::set<std::string> seen;
  for (int i = 0; i < 100; ++i) {
    const std::string t = NewTokenSecret();
    EXPECT_TRUE(IsWellFormedToken(t)) << t;
    EXPECT_EQ(t.size(), 4u + 43u);
    seen.insert(t);
  }
  EXPECT_EQ(seen.size(), 100u);
}

TEST(TokenSecret, MalformedTokensAreToldApart) {
  const std::string good = NewTokenSecret();
  struct Case {
    const char* name;
    std::string token;
  } cases[] = {
      {"empty", ""},
      {"no prefix", good.substr(4)},
      {"other prefix", "tok_" + good.substr(4)},
      {"one short", good.substr(0, good.size() - 1)},
      {"one long", good + "A"},
      {"bad character", good.substr(0, 10) + "+" + good.substr(11)},
      {"space inside", good.substr(0, 10) + " " + good.substr(11)},
  };
  for (const Case& c : cases) EXPECT_FALSE(IsWellFormedToken(c.token)) << c.name;
}

TEST(TokenName, Validation) {
  EXPECT_TRUE(ValidateTokenName("render-node-01.studio_a").ok());
  EXPECT_FALSE(ValidateTokenName("").ok());
  EXPECT_FALSE(ValidateTokenName(std::string(65, 'a')).ok());
  EXPECT_FALSE(ValidateTokenName("a b").ok());
  EXPECT_FALSE(ValidateTokenName("a/b").ok());
  EXPECT_FALSE(ValidateTokenName("\"quoted\"").ok());
}

TEST(TokenStore, InsertFindListRevokeAndReuseTheName) {
  auto store = OpenSqliteTokenStore(TempDir("store"));
  ASSERT_TRUE(store.ok()) << store.status();
  const std::string secret = NewTokenSecret();
  TokenRecord r{.name = "ci", .role = Role::kSubmitter, .secret_hash = TokenHash(secret), .created_ms = 1000,
                .expires_ms = 5000};
  ASSERT_TRUE((*store)->Insert(r).ok());
  TokenRecord twin = r;
  twin.secret_hash = TokenHash(NewTokenSecret());
  EXPECT_EQ((*store)->Insert(twin).code(), absl::StatusCode::kAlreadyExists);

  auto found = (*store)->FindByHash(TokenHash(secret));
  ASSERT_TRUE(found.ok() && found->has_value());
  EXPECT_EQ((*found)->name, "ci");
  EXPECT_EQ((*found)->role, Role::kSubmitter);
  EXPECT_EQ((*found)->expires_ms, 5000);
  auto missing = (*store)->FindByHash(TokenHash(NewTokenSecret()));
  ASSERT_TRUE(missing.ok());
  EXPECT_FALSE(missing->has_value());

  EXPECT_EQ((*store)->Revoke("nobody", 2000).code(), absl::StatusCode::kNotFound);
  ASSERT_TRUE((*store)->Revoke("ci", 2000).ok());
  EXPECT_EQ((*store)->Revoke("ci", 2001).code(), absl::StatusCode::kNotFound);
  // The name is free again for a successor; the revoked one stays listed.
  ASSERT_TRUE((*store)->Insert(twin).ok());
  auto all = (*store)->List();
  ASSERT_TRUE(all.ok());
  ASSERT_EQ(all->size(), 2u);
  EXPECT_EQ((*all)[0].revoked_ms, 2000);
  EXPECT_EQ((*all)[1].revoked_ms, 0);
  // The secret is nowhere in the database file.
  std::ifstream db(fs::path(TempDir("unused")).parent_path() /
                   ("impostor_auth_" + std::to_string(::getpid()) + "_store") / "tokens.sqlite3", std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(db)), {});
  EXPECT_EQ(bytes.find(secret.substr(4)), std::string::npos);
}

class AuthenticatorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto s = OpenSqliteTokenStore(TempDir(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    ASSERT_TRUE(s.ok()) << s.status();
    store_ = std::move(*s);
  }
  std::string Add(const std::string& name, Role role, int64_t expires_ms = 0) {
    const std::string secret = NewTokenSecret();
    EXPECT_TRUE(store_->Insert({.name = name, .role = role, .secret_hash = TokenHash(secret), .created_ms = now_,
                                .expires_ms = expires_ms})
                    .ok());
    return secret;
  }
  absl::StatusOr<Principal> Call(Authenticator& a, const std::string& header) { return a.Authenticate(&header); }

  std::unique_ptr<TokenStore> store_;
  int64_t now_ = 1'700'000'000'000;
};

TEST_F(AuthenticatorTest, EachRefusalNamesItsReasonAndNeverTheSecret) {
  Authenticator auth(store_.get(), 2000, [this] { return now_; });
  const std::string expired = Add("old", Role::kReader, now_ + 10);
  const std::string revoked = Add("gone", Role::kReader);
  ASSERT_TRUE(store_->Revoke("gone", now_).ok());
  const std::string unknown = NewTokenSecret();
  now_ += 100;
  struct Case {
    const char* name;
    const std::string* header;
    std::string value;
    const char* reason;
    std::string secret;
  } cases[] = {
      {"no header", nullptr, "", "no token", ""},
      {"basic auth", &cases[1].value, "Basic dXNlcjpwYXNz", "malformed authorization", ""},
      {"bearer without token", &cases[2].value, "Bearer ", "malformed token", ""},
      {"not our format", &cases[3].value, "Bearer abc.def.ghi", "malformed token", "abc.def.ghi"},
      {"unknown", &cases[4].value, "Bearer " + unknown, "unknown token", unknown},
      {"expired", &cases[5].value, "Bearer " + expired, "expired token: 'old'", expired},
      {"revoked", &cases[6].value, "Bearer " + revoked, "revoked token: 'gone'", revoked},
  };
  for (const Case& c : cases) {
    auto p = auth.Authenticate(c.header);
    ASSERT_FALSE(p.ok()) << c.name;
    EXPECT_EQ(p.status().code(), absl::StatusCode::kUnauthenticated) << c.name;
    EXPECT_NE(p.status().message().find(c.reason), std::string::npos) << c.name << ": " << p.status();
    if (!c.secret.empty()) {
      EXPECT_EQ(p.status().message().find(c.secret), std::string::npos) << c.name;
    }
  }
}

TEST_F(AuthenticatorTest, ValidTokenGivesItsPrincipal) {
  Authenticator auth(store_.get(), 2000, [this] { return now_; });
  const std::string secret = Add("artist", Role::kSubmitter);
  auto p = Call(auth, "Bearer " + secret);
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(p->name, "artist");
  EXPECT_EQ(p->role, Role::kSubmitter);
  // The scheme is case-insensitive (RFC 7235); the token is not.
  for (const char* scheme : {"bearer ", "BEARER "}) {
    auto q = Call(auth, scheme + secret);
    ASSERT_TRUE(q.ok()) << scheme << ": " << q.status();
    EXPECT_EQ(q->name, "artist");
  }
  auto listed = store_->List();
  ASSERT_TRUE(listed.ok());
  EXPECT_EQ((*listed)[0].last_used_ms, now_);
}

// The token's default required tags (issue 44) travel with its principal
// to SubmitBake; a token without any gives none.
TEST_F(AuthenticatorTest, ATokensRequiredTagsReachItsPrincipal) {
  Authenticator auth(store_.get(), 2000, [this] { return now_; });
  const std::string forest = NewTokenSecret();
  ASSERT_TRUE(store_
                  ->Insert({.name = "forest-ci", .role = Role::kSubmitter, .secret_hash = TokenHash(forest),
                            .created_ms = now_, .required_tags = {"team-forest", "gpu"}})
                  .ok());
  const std::string plain = Add("artist", Role::kSubmitter);
  auto p = Call(auth, "Bearer " + forest);
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(p->name, "forest-ci");
  EXPECT_EQ(p->required_tags, (std::vector<std::string>{"gpu", "team-forest"}));
  auto cached = Call(auth, "Bearer " + forest);
  ASSERT_TRUE(cached.ok()) << cached.status();
  EXPECT_EQ(cached->required_tags, p->required_tags) << "from the cache too";
  auto q = Call(auth, "Bearer " + plain);
  ASSERT_TRUE(q.ok()) << q.status();
  EXPECT_TRUE(q->required_tags.empty());
}

// `token create --require-tag`: the request's rule under the flag's name.
TEST(TokenRequireTag, SortsDropsRepeatsAndRefusesNamingTheFlagAndTheLimit) {
  auto ok = NormalizeTokenRequiredTags({"team-forest", "gpu", "team-forest"});
  ASSERT_TRUE(ok.ok()) << ok.status();
  EXPECT_EQ(*ok, (std::vector<std::string>{"gpu", "team-forest"}));
  std::vector<std::string> seventeen;
  for (int i = 0; i < 17; ++i) seventeen.push_back("t" + std::to_string(i));
  struct Case {
    const char* name;
    std::vector<std::string> tags;
    const char* expected;
  } cases[] = {
      {"upper case", {"gpu", "GPU"}, "--require-tag: \"GPU\" is not 1..64 bytes of [a-z0-9._-]"},
      {"empty", {""}, "--require-tag: \"\" is not 1..64 bytes of [a-z0-9._-]"},
      {"too long", {std::string(65, 'x')}, "is not 1..64 bytes of [a-z0-9._-]"},
      {"space", {"team forest"}, "--require-tag: \"team forest\" is not"},
      {"control byte", {"gpu\n"}, "--require-tag: \"gpu\\n\" is not"},
      {"17 tags", seventeen, "--require-tag: 17 tags is over the limit of 16"},
  };
  for (const Case& c : cases) {
    auto r = NormalizeTokenRequiredTags(c.tags);
    ASSERT_FALSE(r.ok()) << c.name;
    EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument) << c.name;
    EXPECT_NE(r.status().message().find(c.expected), std::string::npos) << c.name << ": " << r.status();
  }
  seventeen.pop_back();
  EXPECT_TRUE(NormalizeTokenRequiredTags(seventeen).ok()) << "16 is the limit, not over it";
  for (Role role : {Role::kReader, Role::kWorker}) {
    const absl::Status s = CheckRequiredTagsFitRole(role, {"gpu"});
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << RoleName(role);
    EXPECT_NE(s.message().find("token submits no bakes"), std::string::npos) << s;
    EXPECT_TRUE(CheckRequiredTagsFitRole(role, {}).ok()) << RoleName(role);
  }
  for (Role role : {Role::kSubmitter, Role::kAdmin}) EXPECT_TRUE(CheckRequiredTagsFitRole(role, {"gpu"}).ok());
}

// SubmitBake's tags: the request's and the token's, as one sorted list
// without repeats, and never more than 16 together.
TEST(SubmitTags, TheTokensDefaultsJoinTheRequestsWithinTheLimit) {
  const Principal forest{.name = "forest-ci", .role = Role::kSubmitter, .required_tags = {"team-forest"}};
  const Principal plain{.name = "artist", .role = Role::kSubmitter};
  std::vector<std::string> sixteen;  // r00 .. r15, sorted
  for (int i = 0; i < 16; ++i) sixteen.push_back("r" + std::to_string(i / 10) + std::to_string(i % 10));
  const std::vector<std::string> fifteen(sixteen.begin(), sixteen.end() - 1);
  std::vector<std::string> fifteen_and_forest = fifteen;
  fifteen_and_forest.push_back("team-forest");
  struct Case {
    const char* name;
    std::vector<std::string> request;
    Principal caller;
    std::vector<std::string> expected;
  } cases[] = {
      {"token only", {}, forest, {"team-forest"}},
      {"request only", {"gpu"}, plain, {"gpu"}},
      {"both", {"gpu", "zone-b"}, forest, {"gpu", "team-forest", "zone-b"}},
      {"the same tag twice", {"gpu", "team-forest"}, forest, {"gpu", "team-forest"}},
      {"neither", {}, plain, {}},
      {"anonymous admin (--auth none)", {"gpu"}, Principal{}, {"gpu"}},
      {"16 together", fifteen, forest, fifteen_and_forest},
      {"16 in the request, one of them the token's", sixteen, Principal{.name = "t", .required_tags = {"r00"}},
       sixteen},
  };
  for (const Case& c : cases) {
    auto merged = WithTokenRequiredTags(c.request, c.caller);
    ASSERT_TRUE(merged.ok()) << c.name << ": " << merged.status();
    EXPECT_EQ(*merged, c.expected) << c.name;
  }
  auto over = WithTokenRequiredTags(sixteen, forest);
  ASSERT_FALSE(over.ok());
  EXPECT_EQ(over.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(over.status().message().find(
                "required_tags: the request's 16 and token 'forest-ci''s 1 default tags make 17, over the limit of 16"),
            std::string::npos)
      << over.status();
}

TEST_F(AuthenticatorTest, RevocationIsSeenOnceTheTtlPasses) {
  Authenticator auth(store_.get(), 2000, [this] { return now_; });
  const std::string secret = Add("worker-7", Role::kWorker);
  ASSERT_TRUE(Call(auth, "Bearer " + secret).ok());
  ASSERT_TRUE(store_->Revoke("worker-7", now_).ok());
  now_ += 1999;  // still cached
  EXPECT_TRUE(Call(auth, "Bearer " + secret).ok());
  now_ += 1;
  auto p = Call(auth, "Bearer " + secret);
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.status().code(), absl::StatusCode::kUnauthenticated);
}

TEST_F(AuthenticatorTest, ExpiryNeedsNoDatabaseRead) {
  Authenticator auth(store_.get(), 60'000, [this] { return now_; });
  const std::string secret = Add("temp", Role::kReader, now_ + 500);
  ASSERT_TRUE(Call(auth, "Bearer " + secret).ok());
  now_ += 500;
  auto p = Call(auth, "Bearer " + secret);
  ASSERT_FALSE(p.ok());
  EXPECT_NE(p.status().message().find("expired"), std::string::npos);
}

// The role table, cell by cell for the method level (per-object checks are
// exercised against a real server in tests/integration/auth_test.cc).
TEST(AccessPolicy, RoleTable) {
  const std::string a = "/impostor.v1.AssetService/", b = "/impostor.v1.BakeService/",
                    w = "/impostor.v1.WorkerService/";
  struct Row {
    std::string method;
    bool reader, submitter, worker;
  } rows[] = {
      {a + "GetResult", true, true, false},        {a + "ReadBlob", true, true, true},
      {a + "BatchReadBlobs", true, true, true},
      {a + "FindMissingBlobs", false, true, true}, {a + "UploadBlob", false, true, true},
      {a + "BatchUpdateBlobs", false, true, true},
      {a + "QueryUpload", false, true, true},      {a + "PinResult", false, false, false},
      {b + "LookupBake", true, true, false},
      {b + "SubmitBake", false, true, false},      {b + "WatchJob", false, true, false},
      {b + "GetJob", false, true, false},          {b + "CancelJob", false, true, false},
      {w + "LeaseJob", false, false, true},        {w + "ReportProgress", false, false, true},
      {w + "CompleteJob", false, false, true},     {w + "FailJob", false, false, true},
      {w + "ReleaseJob", false, false, true},
      {"/impostor.v1.AdminService/PurgeWorkerResults", false, false, false},
      // Not in the table: admin only.
      {"/impostor.v1.AdminService/Purge", false, false, false},
  };
  for (const Row& row : rows) {
    for (auto [role, allowed] : {std::pair{Role::kReader, row.reader}, std::pair{Role::kSubmitter, row.submitter},
                                 std::pair{Role::kWorker, row.worker}, std::pair{Role::kAdmin, true}}) {
      const absl::Status s = AuthorizeMethod({"t", role}, row.method);
      EXPECT_EQ(s.ok(), allowed) << row.method << " as " << RoleName(role) << ": " << s;
      if (!s.ok()) {
        EXPECT_EQ(s.code(), absl::StatusCode::kPermissionDenied);
        EXPECT_NE(s.message().find("needs role"), std::string::npos) << s;
        EXPECT_NE(s.message().find("admin"), std::string::npos) << s;
      }
    }
  }
  // Every rule in the table is a row above (the last is not a rule).
  EXPECT_EQ(AccessRules().size(), std::size(rows) - 1);
  const MethodRule* purge = FindRule("/impostor.v1.AdminService/PurgeWorkerResults");
  ASSERT_NE(purge, nullptr);
  EXPECT_TRUE(purge->changes_state) << "purges are audited";
}

TEST(AuthMode, DefaultsAndRefusals) {
  struct Case {
    const char* flag;
    const char* listen;
    bool ok;
    AuthMode mode;
  } cases[] = {
      {"", "localhost:50051", true, AuthMode::kNone},     {"", "127.0.0.1:0", true, AuthMode::kNone},
      {"", "[::1]:50051", true, AuthMode::kNone},         {"", "0.0.0.0:50051", true, AuthMode::kToken},
      {"", "farm.studio:50051", true, AuthMode::kToken},  {"", "127.evil.com:1", true, AuthMode::kToken},
      {"token", "127.0.0.1:0", true, AuthMode::kToken},   {"none", "127.0.0.2:1", true, AuthMode::kNone},
      {"none", "0.0.0.0:50051", false, AuthMode::kNone},  {"none", "[::]:50051", false, AuthMode::kNone},
      {"maybe", "127.0.0.1:0", false, AuthMode::kNone},
  };
  for (const Case& c : cases) {
    auto m = ResolveAuthMode(c.flag, c.listen);
    EXPECT_EQ(m.ok(), c.ok) << c.flag << " " << c.listen;
    if (m.ok()) {
      EXPECT_EQ(*m, c.mode) << c.flag << " " << c.listen;
    }
  }
  auto refused = ResolveAuthMode("none", "10.0.0.5:50051");
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("not a loopback address"), std::string::npos);

  // The HTTP front end serves the same jobs and meshes: a network-facing
  // one turns tokens on by default and refuses none, even with a loopback
  // gRPC port.
  EXPECT_EQ(*ResolveAuthMode("", "127.0.0.1:0", "0.0.0.0:8080"), AuthMode::kToken);
  EXPECT_EQ(*ResolveAuthMode("", "127.0.0.1:0", "127.0.0.1:8080"), AuthMode::kNone);
  EXPECT_EQ(*ResolveAuthMode("", "127.0.0.1:0", ""), AuthMode::kNone) << "no HTTP front end";
  auto http_refused = ResolveAuthMode("none", "127.0.0.1:0", "0.0.0.0:8080");
  ASSERT_FALSE(http_refused.ok());
  EXPECT_NE(http_refused.status().message().find("--auth none: refused with --http-listen 0.0.0.0:8080"),
            std::string::npos)
      << http_refused.status();
}

TEST(ExpiresIn, ParsesUnitsAndRefusesTheRest) {
  EXPECT_EQ(*ParseExpiresIn("90d"), int64_t{90} * 86'400'000);
  EXPECT_EQ(*ParseExpiresIn("12h"), int64_t{12} * 3'600'000);
  EXPECT_EQ(*ParseExpiresIn("30m"), 30 * 60'000);
  EXPECT_EQ(*ParseExpiresIn("1s"), 1000);
  for (const char* bad : {"", "d", "0d", "-1d", "1w", "1.5d", "90", "3651d", "99999999999d", " 1d"}) {
    auto r = ParseExpiresIn(bad);
    EXPECT_FALSE(r.ok()) << bad;
    if (!r.ok()) {
      EXPECT_NE(r.status().message().find("--expires-in"), std::string::npos);
    }
  }
}

TEST(TokenSource, FileWinsThenTokenThenEnvironment) {
  const fs::path dir = TempDir("source");
  const fs::path file = dir / "token";
  std::ofstream(file) << "  imp_from_file  \nsecond line ignored\n";
  EXPECT_EQ(*ResolveToken(file.string(), "imp_direct", "imp_env"), "imp_from_file");
  EXPECT_EQ(*ResolveToken("", "imp_direct", "imp_env"), "imp_direct");
  EXPECT_EQ(*ResolveToken("", "", "imp_env"), "imp_env");
  EXPECT_EQ(*ResolveToken("", "", nullptr), "");

  std::ofstream(dir / "empty") << "\n";
  std::ofstream(dir / "second") << "\nimp_a\n";
  std::ofstream(dir / "spaced") << "imp_a imp_b\n";
  std::ofstream(dir / "huge") << std::string(5000, 'a');
  struct Case {
    const char* name;
    fs::path file;
    std::string expected;
  } cases[] = {{"missing", dir / "nope", "cannot read " + (dir / "nope").string() + ": No such file or directory"},
               {"empty", dir / "empty", "is empty"},
               {"token on the second line", dir / "second", "its first line is empty"},
               {"a directory", dir, "is a directory, not a file"},
               {"two tokens", dir / "spaced", "space or control"},
               {"huge", dir / "huge", "over 4096 bytes"}};
  for (const Case& c : cases) {
    auto r = ResolveToken(c.file.string(), "", "imp_env");
    ASSERT_FALSE(r.ok()) << c.name;
    EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument) << c.name;
    EXPECT_NE(r.status().message().find(c.expected), std::string::npos) << c.name << ": " << r.status();
    EXPECT_EQ(r.status().message().find("imp_a"), std::string::npos) << c.name;
  }
}

}  // namespace
}  // namespace impostor

namespace impostor {
namespace {

TEST(TokenQuotas, WindowsSlideAndRefusalsNameCountAndLimit) {
  int64_t now = 1'700'000'000'000;
  TokenQuotas quotas({.max_pending_jobs = 2, .max_upload_bytes_per_day = 1000, .max_bakes_per_hour = 2},
                     [&] { return now; });
  EXPECT_TRUE(quotas.CheckSubmit("ci", 1).ok());
  absl::Status s = quotas.CheckSubmit("ci", 2);
  EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted);
  EXPECT_NE(s.message().find("pending jobs of token 'ci': 2 queued or running, the limit per token is 2"),
            std::string::npos)
      << s;
  EXPECT_EQ(ErrorReasonOf(s), "TOKEN_PENDING_JOBS");

  quotas.RecordBake("ci");
  now += 1000;
  quotas.RecordBake("ci");
  s = quotas.CheckSubmit("ci", 0);
  EXPECT_NE(s.message().find("bakes of token 'ci': 2 in the last hour"), std::string::npos) << s;
  EXPECT_EQ(ErrorReasonOf(s), "TOKEN_BAKES_PER_HOUR");
  EXPECT_TRUE(quotas.CheckSubmit("other", 0).ok()) << "quotas are per token";
  now += 3'600'000 - 1000;  // the first bake leaves the window
  EXPECT_TRUE(quotas.CheckSubmit("ci", 0).ok());

  quotas.RecordUpload("ci", 999);
  EXPECT_TRUE(quotas.CheckUpload("ci").ok());
  quotas.RecordUpload("ci", 1);
  s = quotas.CheckUpload("ci");
  EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted);
  EXPECT_NE(s.message().find("1000 bytes in the last 24 hours, the limit per token is 1000"), std::string::npos) << s;
  EXPECT_EQ(ErrorReasonOf(s), "TOKEN_UPLOAD_BYTES_PER_DAY");
  now += 24 * 3'600'000;
  EXPECT_TRUE(quotas.CheckUpload("ci").ok());
}

// The windows live in the token database: a new TokenQuotas on the same
// directory (a restarted server) still counts what the old one recorded, and
// the token store beside it is untouched.
TEST(TokenQuotas, SqliteLedgerKeepsWindowsAcrossARestart) {
  int64_t now = 1'700'000'000'000;
  const fs::path dir = TempDir("quota_ledger");
  const QuotaOptions options{.max_pending_jobs = 10, .max_upload_bytes_per_day = 1000, .max_bakes_per_hour = 2};
  {
    auto tokens = OpenSqliteTokenStore(dir);
    ASSERT_TRUE(tokens.ok()) << tokens.status();
    ASSERT_TRUE((*tokens)->Insert({.name = "ci", .secret_hash = TokenHash(NewTokenSecret())}).ok());
    auto ledger = OpenSqliteQuotaLedger(dir);
    ASSERT_TRUE(ledger.ok()) << ledger.status();
    TokenQuotas quotas(options, [&] { return now; }, std::move(*ledger));
    quotas.RecordBake("ci");
    quotas.RecordBake("ci");
    quotas.RecordUpload("ci", 1200);
    quotas.RecordUpload("other", 5);
  }
  auto ledger = OpenSqliteQuotaLedger(dir);
  ASSERT_TRUE(ledger.ok()) << ledger.status();
  TokenQuotas quotas(options, [&] { return now; }, std::move(*ledger));
  absl::Status s = quotas.CheckSubmit("ci", 0);
  EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted) << s;
  EXPECT_NE(s.message().find("bakes of token 'ci': 2 in the last hour, the limit per token is 2"), std::string::npos)
      << s;
  s = quotas.CheckUpload("ci");
  EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted) << s;
  EXPECT_NE(s.message().find("1200 bytes in the last 24 hours, the limit per token is 1000"), std::string::npos) << s;
  EXPECT_TRUE(quotas.CheckUpload("other").ok());
  now += 3'600'000;  // the bakes leave their window, the uploads not yet
  EXPECT_TRUE(quotas.CheckSubmit("ci", 0).ok());
  EXPECT_EQ(quotas.CheckUpload("ci").code(), absl::StatusCode::kResourceExhausted);
  now += 23 * 3'600'000;
  EXPECT_TRUE(quotas.CheckUpload("ci").ok());
  // Recording a day later forgets the day-old events for good.
  quotas.RecordUpload("ci", 1);
  auto reopened = OpenSqliteQuotaLedger(dir);
  ASSERT_TRUE(reopened.ok());
  auto old_sum = (*reopened)->Sum("ci", "upload_bytes", 0);
  ASSERT_TRUE(old_sum.ok()) << old_sum.status();
  EXPECT_EQ(*old_sum, 1);
  auto tokens = OpenSqliteTokenStore(dir);
  ASSERT_TRUE(tokens.ok());
  auto listed = (*tokens)->List();
  ASSERT_TRUE(listed.ok());
  ASSERT_EQ(listed->size(), 1u);
  EXPECT_EQ((*listed)[0].name, "ci");
}

}  // namespace
}  // namespace impostor

namespace impostor {
namespace {

// A job database from before tokens (no owner/lease_holder columns, no
// result_blobs table) opens with its jobs and results intact, its jobs
// owned by nobody, and its results' blobs readable as result blobs.
TEST(JobStoreMigration, DatabaseFromBeforeTokensKeepsWorking) {
  const fs::path dir = TempDir("migration");
  const fs::path file = dir / "jobs.sqlite3";
  v1::Manifest manifest;
  manifest.set_cache_key(std::string(64, 'a'));
  manifest.mutable_manifest_json()->set_hash(std::string(64, 'b'));
  manifest.add_maps()->mutable_digest()->set_hash(std::string(64, 'c'));
  v1::Job job;
  job.set_job_id("job-old");
  job.set_cache_key(manifest.cache_key());
  job.set_state(v1::JOB_STATE_QUEUED);
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
    const char* old_schema = R"sql(
      CREATE TABLE jobs (job_id TEXT PRIMARY KEY, cache_key TEXT NOT NULL, state INTEGER NOT NULL,
        created_ms INTEGER NOT NULL, lease_id TEXT NOT NULL DEFAULT '', lease_deadline_ms INTEGER NOT NULL DEFAULT 0,
        worker_id TEXT NOT NULL DEFAULT '', job BLOB NOT NULL, request BLOB NOT NULL,
        leader_job_id TEXT NOT NULL DEFAULT '', requester_cancelled INTEGER NOT NULL DEFAULT 0,
        client_id TEXT NOT NULL DEFAULT '', priority INTEGER NOT NULL DEFAULT 0,
        request_id TEXT NOT NULL DEFAULT '', lease_expiries INTEGER NOT NULL DEFAULT 0);
      CREATE TABLE results (cache_key TEXT PRIMARY KEY, manifest BLOB NOT NULL, created_ms INTEGER NOT NULL,
        last_used_ms INTEGER NOT NULL DEFAULT 0, pinned INTEGER NOT NULL DEFAULT 0);)sql";
    ASSERT_EQ(sqlite3_exec(db, old_schema, nullptr, nullptr, nullptr), SQLITE_OK) << sqlite3_errmsg(db);
    sqlite3_stmt* st = nullptr;
    ASSERT_EQ(sqlite3_prepare_v2(db, "INSERT INTO results (cache_key, manifest, created_ms) VALUES (?1, ?2, 1)", -1,
                                 &st, nullptr),
              SQLITE_OK);
    const std::string m = manifest.SerializeAsString();
    sqlite3_bind_text(st, 1, manifest.cache_key().c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_bind_blob(st, 2, m.data(), static_cast<int>(m.size()), SQLITE_TRANSIENT);
    ASSERT_EQ(sqlite3_step(st), SQLITE_DONE);
    sqlite3_finalize(st);
    ASSERT_EQ(sqlite3_prepare_v2(db,
                                 "INSERT INTO jobs (job_id, cache_key, state, created_ms, job, request, client_id) "
                                 "VALUES ('job-old', ?1, 1, 1, ?2, x'', 'ci')",
                                 -1, &st, nullptr),
              SQLITE_OK);
    const std::string j = job.SerializeAsString();
    sqlite3_bind_text(st, 1, manifest.cache_key().c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_bind_blob(st, 2, j.data(), static_cast<int>(j.size()), SQLITE_TRANSIENT);
    ASSERT_EQ(sqlite3_step(st), SQLITE_DONE);
    sqlite3_finalize(st);
    sqlite3_close(db);
  }
  auto store = JobStore::Open(file);
  ASSERT_TRUE(store.ok()) << store.status();
  auto old = (*store)->Get("job-old");
  ASSERT_TRUE(old.ok() && old->has_value()) << old.status();
  EXPECT_EQ((*old)->owner, "");
  EXPECT_EQ((*old)->client_id, "ci");
  EXPECT_TRUE(*(*store)->IsResultBlob(std::string(64, 'b')));
  EXPECT_TRUE(*(*store)->IsResultBlob(std::string(64, 'c')));
  EXPECT_FALSE(*(*store)->IsResultBlob(std::string(64, 'd')));
  auto result = (*store)->GetResult(manifest.cache_key());
  ASSERT_TRUE(result.ok() && result->has_value());
  EXPECT_EQ((*result)->baked_by(), "");
  // New rows carry the new columns.
  JobRecord fresh = **old;
  fresh.job.set_job_id("job-new");
  // Another key: one queued bake per cache key is a constraint (issue 15).
  fresh.job.set_cache_key(std::string(64, 'e'));
  fresh.owner = "artist";
  fresh.lease_holder = "node-1";
  ASSERT_TRUE((*store)->Insert(fresh).ok());
  EXPECT_EQ((*(*store)->Get("job-new"))->owner, "artist");
  EXPECT_EQ(*(*store)->CountPendingOwnedBy("artist"), 1);
  // A purged result's blobs are no longer result blobs.
  ASSERT_TRUE((*store)->DeleteResult(manifest.cache_key()).ok());
  EXPECT_FALSE(*(*store)->IsResultBlob(std::string(64, 'c')));
}

}  // namespace
}  // namespace impostor
