// Tokens and quotas shared by server replicas on one PostgreSQL database
// (issue 15), with real processes: two impostor-servers with the same
// --database and --blob-dir and --auth token, and `impostor-server token
// ... --database URL`. A token created through the command authenticates on
// both replicas, a quota spent across both is counted once, and a revoked
// token is refused by both (--token-cache-ttl-ms=0 makes the refusal
// immediate; the default 2 s cache is tested with a fake clock in
// tests/server/token_store_contract_test.cc). The command's bad inputs are
// refused naming the flag, against PostgreSQL as against --data.
#include <algorithm>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/published_result.h"
#include "tests/support/server_process.h"
#include "tests/support/postgres_instance.h"

namespace impostor::testing {
namespace {

using grpc::StatusCode;

class SharedTokensFarm : public ::testing::Test {
 protected:
  void SetUp() override {
    auto pg = PostgresInstance::Start();
    ASSERT_TRUE(pg.ok()) << pg.status();
    pg_ = std::move(*pg);
    ASSERT_TRUE(pg_->CreateDatabase("farm").ok());
    url_ = pg_->Url("farm");
    blobs_ = NewTempDir("shared_tokens_blobs");
    const std::vector<std::string> args = {"--database=" + url_, "--blob-dir=" + blobs_.string(), "--auth=token",
                                           "--token-cache-ttl-ms=0", "--token-max-bakes-per-hour=2"};
    a_ = std::make_unique<ServerProcess>(0, args);
    b_ = std::make_unique<ServerProcess>(0, args);
  }

  ToolRun Token(std::vector<std::string> args) {
    std::vector<std::string> argv = {(BinaryDir() / "impostor-server").string(), "token"};
    argv.insert(argv.end(), args.begin(), args.end());
    return RunTool(argv, kStartTimeout);
  }

  // Uploads a small model and submits it through `server` as `token`.
  grpc::Status Submit(ServerProcess& server, const std::string& token, uint32_t seed) {
    const std::string model = "glTF" + RandomBytes(64, seed);
    {
      auto ctx = ContextWithAuthorization("Bearer " + token);
      v1::UploadBlobResponse response;
      auto writer = server.assets().UploadBlob(ctx.get(), &response);
      v1::UploadBlobRequest chunk;
      *chunk.mutable_digest() = DigestOf(model);
      chunk.set_data(model);
      writer->Write(chunk);
      writer->WritesDone();
      if (grpc::Status s = writer->Finish(); !s.ok()) return s;
    }
    v1::SubmitBakeRequest request;
    request.mutable_mesh()->mutable_entry()->set_path("model.glb");
    *request.mutable_mesh()->mutable_entry()->mutable_digest() = DigestOf(model);
    auto ctx = ContextWithAuthorization("Bearer " + token);
    v1::SubmitBakeResponse response;
    return server.bake().SubmitBake(ctx.get(), request, &response);
  }

  std::unique_ptr<PostgresInstance> pg_;
  std::string url_;
  std::filesystem::path blobs_;
  std::unique_ptr<ServerProcess> a_, b_;
};

TEST_F(SharedTokensFarm, TokenCreatedOnceWorksOnBothQuotaCountsOnceRevocationReachesBoth) {
  const ToolRun created = Token({"create", "--database=" + url_, "--role=submitter", "--name=ci"});
  ASSERT_EQ(created.exit_code, 0) << created.err;
  const std::string ci = created.out.substr(0, created.out.find('\n'));

  // --token-max-bakes-per-hour=2 on each replica, counted in the shared
  // ledger: one bake on A and one on B use the token's hour up on both.
  grpc::Status s = Submit(*a_, ci, 1);
  ASSERT_TRUE(s.ok()) << s.error_message();
  s = Submit(*b_, ci, 2);
  ASSERT_TRUE(s.ok()) << s.error_message();
  for (ServerProcess* replica : {a_.get(), b_.get()}) {
    s = Submit(*replica, ci, 3);
    EXPECT_EQ(s.error_code(), StatusCode::RESOURCE_EXHAUSTED) << replica->address() << ": " << s.error_message();
    EXPECT_NE(s.error_message().find("bakes of token 'ci': 2 in the last hour, the limit per token is 2"),
              std::string::npos)
        << s.error_message();
  }

  const ToolRun listed = Token({"list", "--database=" + url_});
  ASSERT_EQ(listed.exit_code, 0) << listed.err;
  EXPECT_NE(listed.out.find("ci "), std::string::npos) << listed.out;
  EXPECT_NE(listed.out.find("active"), std::string::npos) << listed.out;
  EXPECT_EQ(listed.out.find(ci), std::string::npos) << "the secret is never listed";

  const ToolRun revoked = Token({"revoke", "--database=" + url_, "--name=ci"});
  ASSERT_EQ(revoked.exit_code, 0) << revoked.err;
  for (ServerProcess* replica : {a_.get(), b_.get()}) {
    s = Submit(*replica, ci, 4);
    EXPECT_EQ(s.error_code(), StatusCode::UNAUTHENTICATED) << replica->address() << ": " << s.error_message();
    EXPECT_NE(s.error_message().find("revoked token: 'ci'"), std::string::npos) << s.error_message();
  }
  // A successor of the same name works at once on both.
  const ToolRun successor = Token({"create", "--database=" + url_, "--role=admin", "--name=ci"});
  ASSERT_EQ(successor.exit_code, 0) << successor.err;
  const std::string ci2 = successor.out.substr(0, successor.out.find('\n'));
  EXPECT_TRUE(Submit(*b_, ci2, 5).ok()) << "admins are exempt from quotas";
  EXPECT_TRUE(Submit(*a_, ci2, 6).ok());
}

// The first command on a new database migrates its schema and logs that;
// the log must go to stderr, or a script's `token create > worker.token`
// captures it instead of the secret (the multi-host test once did).
TEST_F(SharedTokensFarm, CreateOnAFreshDatabasePrintsOnlyTheSecretOnStdout) {
  ASSERT_TRUE(pg_->CreateDatabase("fresh").ok());
  const ToolRun created = Token({"create", "--database=" + pg_->Url("fresh"), "--role=worker", "--name=w"});
  ASSERT_EQ(created.exit_code, 0) << created.err;
  EXPECT_NE(created.err.find("event=schema_migrated"), std::string::npos) << "the migration is logged: " << created.err;
  ASSERT_EQ(std::count(created.out.begin(), created.out.end(), '\n'), 1) << created.out;
  const std::string secret = created.out.substr(0, created.out.size() - 1);
  EXPECT_GE(secret.size(), 32u) << secret;
  EXPECT_EQ(secret.find_first_of(" \t\r="), std::string::npos) << secret;
}

TEST_F(SharedTokensFarm, BadCommandLinesAreRefusedNamingTheFlag) {
  const std::string db = "--database=" + url_;
  struct Case {
    const char* name;
    std::vector<std::string> args;
    int exit_code;
    const char* expected;
  } cases[] = {
      {"unknown role", {"create", db, "--role=superuser", "--name=x"}, 2, "--role: \"superuser\" is not a role"},
      {"empty name", {"create", db, "--role=reader", "--name="}, 2, "--name: must be 1..64 characters, got 0"},
      {"too-long name", {"create", db, "--role=reader", "--name=" + std::string(65, 'n')}, 2,
       "--name: must be 1..64 characters, got 65"},
      {"revoke unknown", {"revoke", db, "--name=nobody"}, 1, "--name: no live token named 'nobody'"},
      {"other scheme", {"list", "--database=mysql://u:hunter2@db/farm"}, 2, "--database: expected a postgresql://"},
      {"neither", {"list"}, 2, "--data: required (the server's data directory), or --database"},
      {"unreachable", {"list", "--database=postgresql://farm:hunter2@127.0.0.1:1/x?connect_timeout=2"}, 1,
       "postgresql://farm:***@127.0.0.1:1/x"},
      // A replica's --data: its tokens are in the database, not there.
      {"a replica's data directory", {"create", "--data=" + a_->data_dir().string(), "--role=reader", "--name=r"}, 2,
       "keeps its tokens in its --database"},
  };
  for (const Case& c : cases) {
    const ToolRun run = Token(c.args);
    EXPECT_EQ(run.exit_code, c.exit_code) << c.name << ": " << run.err;
    EXPECT_NE(run.err.find(c.expected), std::string::npos) << c.name << ": " << run.err;
    EXPECT_EQ(run.err.find("hunter2"), std::string::npos) << c.name << ": " << run.err;
  }
  const ToolRun listed = Token({"list", db});
  ASSERT_EQ(listed.exit_code, 0) << listed.err;
  EXPECT_EQ(listed.out.find("superuser"), std::string::npos) << listed.out;
  EXPECT_EQ(std::count(listed.out.begin(), listed.out.end(), '\n'), 1) << "only the header: " << listed.out;

  const ToolRun bad_ttl = RunTool({(BinaryDir() / "impostor-server").string(), "--listen=127.0.0.1:0",
                                   "--data=" + NewTempDir("bad_ttl").string(), "--auth=token",
                                   "--token-cache-ttl-ms=60001"},
                                  kStartTimeout);
  EXPECT_EQ(bad_ttl.exit_code, 2);
  EXPECT_NE(bad_ttl.err.find("--token-cache-ttl-ms: 60001 is out of range 0..60000"), std::string::npos)
      << bad_ttl.err;
}

}  // namespace
}  // namespace impostor::testing
