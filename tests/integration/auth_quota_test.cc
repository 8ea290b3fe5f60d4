// Per-token quotas, `impostor-server token` and its bad inputs, and --auth
// modes, against real impostor-server processes (issue 14); split from
// auth_test.cc, whose fixture these tests do not use.
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <pwd.h>
#include <sys/stat.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "impostor/v1/admin_service.grpc.pb.h"
#include "tests/support/published_result.h"
#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;
using grpc::StatusCode;

// Each refusal also names its quota in the trailing metadata
// impostor-error-reason (common/error_reason.h), which clients act on.
TEST(AuthQuotas, PerTokenLimitsAnswerResourceExhaustedWithCountAndLimit) {
  ServerProcess server(0, {"--auth=token", "--token-max-pending-jobs=2", "--token-max-bakes-per-hour=3",
                           "--token-max-upload-bytes-per-day=1000"});
  const std::string ci = CreateToken(server.data_dir(), "submitter", "ci");
  const std::string uploader = CreateToken(server.data_dir(), "submitter", "uploader");
  const std::string admin = CreateToken(server.data_dir(), "admin", "ops");
  auto assets = v1::AssetService::NewStub(server.channel());
  auto bake = v1::BakeService::NewStub(server.channel());
  std::string reason;  // the last call's impostor-error-reason
  auto reason_of = [](const grpc::ClientContext& ctx) {
    const auto& trailers = ctx.GetServerTrailingMetadata();
    const auto found = trailers.find("impostor-error-reason");
    return found == trailers.end() ? std::string() : std::string(found->second.data(), found->second.size());
  };
  auto upload = [&](const std::string& token, const std::string& bytes) {
    auto ctx = ContextWithAuthorization("Bearer " + token);
    v1::UploadBlobResponse response;
    auto writer = assets->UploadBlob(ctx.get(), &response);
    v1::UploadBlobRequest chunk;
    *chunk.mutable_digest() = DigestOf(bytes);
    chunk.set_data(bytes);
    writer->Write(chunk);
    writer->WritesDone();
    const grpc::Status s = writer->Finish();
    reason = reason_of(*ctx);
    return s;
  };
  std::vector<std::string> jobs;
  auto submit = [&](const std::string& token, uint32_t seed) {
    const std::string model = "glTF" + RandomBytes(64, seed);
    EXPECT_TRUE(upload(token, model).ok());
    v1::SubmitBakeRequest request;
    request.mutable_mesh()->mutable_entry()->set_path("model.glb");
    *request.mutable_mesh()->mutable_entry()->mutable_digest() = DigestOf(model);
    auto ctx = ContextWithAuthorization("Bearer " + token);
    v1::SubmitBakeResponse response;
    const grpc::Status s = bake->SubmitBake(ctx.get(), request, &response);
    reason = reason_of(*ctx);
    if (s.ok()) jobs.push_back(response.job_id());
    return s;
  };

  // Pending jobs per token (no worker: they stay queued).
  ASSERT_TRUE(submit(ci, 1).ok());
  ASSERT_TRUE(submit(ci, 2).ok());
  grpc::Status s = submit(ci, 3);
  EXPECT_EQ(s.error_code(), StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(s.error_message().find("pending jobs of token 'ci': 2 queued or running, the limit per token is 2"),
            std::string::npos)
      << s.error_message();
  EXPECT_EQ(reason, "TOKEN_PENDING_JOBS");
  EXPECT_TRUE(submit(admin, 4).ok()) << "admins are exempt";
  EXPECT_EQ(reason, "") << "an accepted call carries no reason";
  EXPECT_TRUE(submit(admin, 5).ok());
  EXPECT_TRUE(submit(admin, 6).ok());

  // Bakes per hour count what was submitted, cancelled or not.
  for (size_t i = 0; i < 2; ++i) {
    auto ctx = ContextWithAuthorization("Bearer " + ci);
    v1::CancelJobRequest cancel;
    cancel.set_job_id(jobs[i]);
    v1::Job job;
    ASSERT_TRUE(bake->CancelJob(ctx.get(), cancel, &job).ok());
  }
  ASSERT_TRUE(submit(ci, 7).ok());
  s = submit(ci, 8);
  EXPECT_EQ(s.error_code(), StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(s.error_message().find("bakes of token 'ci': 3 in the last hour, the limit per token is 3 per hour"),
            std::string::npos)
      << s.error_message();
  EXPECT_EQ(reason, "TOKEN_BAKES_PER_HOUR");

  // Upload bytes per day: checked as an upload starts.
  EXPECT_TRUE(upload(uploader, RandomBytes(600, 9)).ok());
  EXPECT_TRUE(upload(uploader, RandomBytes(600, 10)).ok());
  s = upload(uploader, RandomBytes(10, 11));
  EXPECT_EQ(s.error_code(), StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(s.error_message().find("uploads of token 'uploader': 1200 bytes in the last 24 hours, the limit per "
                                   "token is 1000 bytes per day"),
            std::string::npos)
      << s.error_message();
  EXPECT_EQ(reason, "TOKEN_UPLOAD_BYTES_PER_DAY");
  EXPECT_TRUE(upload(admin, RandomBytes(10, 12)).ok());

  // The windows are in the token database: a restart forgives nothing.
  server.Restart();
  assets = v1::AssetService::NewStub(server.channel());
  bake = v1::BakeService::NewStub(server.channel());
  s = submit(ci, 13);
  EXPECT_EQ(s.error_code(), StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
  EXPECT_NE(s.error_message().find("bakes of token 'ci': 3 in the last hour, the limit per token is 3 per hour"),
            std::string::npos)
      << s.error_message();
  s = upload(uploader, RandomBytes(10, 14));
  EXPECT_EQ(s.error_code(), StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
  EXPECT_NE(s.error_message().find("uploads of token 'uploader': 1200 bytes in the last 24 hours, the limit per "
                                   "token is 1000 bytes per day"),
            std::string::npos)
      << s.error_message();

  const ToolRun bad = RunTool({(BinaryDir() / "impostor-server").string(), "--listen=127.0.0.1:0",
                               "--data=" + server.data_dir().string() + "-bad", "--token-max-pending-jobs=0"},
                              kStartTimeout);
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--token-max-pending-jobs"), std::string::npos) << bad.err;
}

// `token create --data DIR` run as root (as an admin does) leaves the token
// database to DIR's owner, the user the server runs as: a root-owned one
// would be read-only to the server and silently stop its quotas.
TEST(AuthTokenCommands, TokenFilesBelongToTheDataDirectorysOwner) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to create a file for another user";
  const fs::path data = NewTempDir("token_owner");
  const passwd* nobody = ::getpwnam("nobody");
  ASSERT_NE(nobody, nullptr);
  ASSERT_EQ(::chown(data.c_str(), nobody->pw_uid, nobody->pw_gid), 0);
  ASSERT_FALSE(CreateToken(data, "worker", "owned").empty());
  struct stat st {};
  ASSERT_EQ(::stat((data / "tokens.sqlite3").c_str(), &st), 0);
  EXPECT_EQ(st.st_uid, nobody->pw_uid);
  EXPECT_EQ(st.st_gid, nobody->pw_gid);
}

TEST(AuthTokenCommands, BadInputsAreRefusedWithTheFieldNamed) {
  const fs::path data = NewTempDir("auth_commands");
  const std::string server = (BinaryDir() / "impostor-server").string();
  const std::vector<std::string> create_submitter = {"token", "create", "--data=" + data.string(), "--role=submitter",
                                                     "--name=a"};
  std::vector<std::string> seventeen_tags = create_submitter;
  for (int i = 0; i < 17; ++i) seventeen_tags.push_back("--require-tag=t" + std::to_string(i));
  const auto with = [](std::vector<std::string> args, const std::vector<std::string>& more) {
    args.insert(args.end(), more.begin(), more.end());
    return args;
  };
  struct Case {
    const char* name;
    std::vector<std::string> args;
    int exit_code;
    const char* message;
  } cases[] = {
      {"no subcommand", {"token"}, 2, "missing subcommand"},
      {"unknown subcommand", {"token", "mint"}, 2, "unknown subcommand \"mint\""},
      {"no data", {"token", "list"}, 2, "--data: required"},
      {"data missing", {"token", "list", "--data=/nonexistent/dir"}, 2, "is not a directory"},
      {"no role", {"token", "create", "--data=" + data.string(), "--name=a"}, 2, "--role: required"},
      {"bad role", {"token", "create", "--data=" + data.string(), "--name=a", "--role=root"}, 2, "is not a role"},
      {"no name", {"token", "create", "--data=" + data.string(), "--role=reader"}, 2, "--name: required"},
      {"bad name", {"token", "create", "--data=" + data.string(), "--role=reader", "--name=a b"}, 2, "--name:"},
      {"bad expiry", {"token", "create", "--data=" + data.string(), "--role=reader", "--name=a", "--expires-in=soon"},
       2, "--expires-in"},
      {"zero expiry", {"token", "create", "--data=" + data.string(), "--role=reader", "--name=a", "--expires-in=0d"},
       2, "--expires-in"},
      {"unknown flag", {"token", "list", "--data=" + data.string(), "--json"}, 2, "unknown argument \"--json\""},
      {"flag twice", {"token", "revoke", "--data=" + data.string(), "--name=a", "--name=b"}, 2, "given twice"},
      {"missing value", {"token", "revoke", "--data=" + data.string(), "--name"}, 2, "--name: missing value"},
      {"revoke unknown", {"token", "revoke", "--data=" + data.string(), "--name=nobody"}, 1, "no live token"},
      // Default required tags (issue 44): a request's rule, under the flag's name.
      {"upper-case tag", with(create_submitter, {"--require-tag=gpu", "--require-tag=GPU"}), 2,
       "--require-tag: \"GPU\" is not 1..64 bytes of [a-z0-9._-]"},
      {"empty tag", with(create_submitter, {"--require-tag="}), 2, "--require-tag: \"\" is not 1..64 bytes"},
      {"tag without a value", with(create_submitter, {"--require-tag"}), 2, "--require-tag: missing value"},
      {"17 tags", seventeen_tags, 2, "--require-tag: 17 tags is over the limit of 16"},
      {"tag on a worker token",
       {"token", "create", "--data=" + data.string(), "--role=worker", "--name=w", "--require-tag=gpu"}, 2,
       "--require-tag: a worker token submits no bakes"},
      {"tag on list", {"token", "list", "--data=" + data.string(), "--require-tag=gpu"}, 2,
       "unknown argument \"--require-tag\" for 'token list'"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> argv = {server};
    argv.insert(argv.end(), c.args.begin(), c.args.end());
    const ToolRun run = RunTool(argv, kStartTimeout);
    EXPECT_EQ(run.exit_code, c.exit_code) << c.name << ": " << run.err;
    EXPECT_NE(run.err.find(c.message), std::string::npos) << c.name << ": " << run.err;
    EXPECT_EQ(run.out, "") << c.name;
  }
  // Create prints exactly one line, the secret; a second live token with
  // the same name is refused.
  const ToolRun created =
      RunTool({server, "token", "create", "--data=" + data.string(), "--role=worker", "--name=node-1"});
  ASSERT_EQ(created.exit_code, 0) << created.err;
  EXPECT_EQ(created.out.size(), 4u + 43u + 1u) << created.out;
  EXPECT_EQ(created.out.rfind("imp_", 0), 0u);
  const ToolRun again =
      RunTool({server, "token", "create", "--data=" + data.string(), "--role=worker", "--name=node-1"});
  EXPECT_EQ(again.exit_code, 1);
  EXPECT_NE(again.err.find("a live token named 'node-1' exists"), std::string::npos) << again.err;
  const ToolRun none = RunTool({server, "token", "list", "--data=" + data.string()});
  ASSERT_EQ(none.exit_code, 0) << none.err;
  for (const char* refused : {"\na ", "\nw "}) {
    EXPECT_EQ(none.out.find(refused), std::string::npos) << "a refused create stored a token:\n" << none.out;
  }
}

// `token create --require-tag` (repeatable): stored sorted without repeats,
// said on create, and shown by `token list` as its last column ("-" for
// none).
TEST(AuthTokenCommands, RequiredTagsAreStoredAndListed) {
  const fs::path data = NewTempDir("auth_token_tags");
  const std::string server = (BinaryDir() / "impostor-server").string();
  const ToolRun created = RunTool({server, "token", "create", "--data=" + data.string(), "--role=submitter",
                                   "--name=forest-ci", "--require-tag", "team-forest", "--require-tag=gpu",
                                   "--require-tag=gpu"});
  ASSERT_EQ(created.exit_code, 0) << created.err;
  EXPECT_NE(created.err.find("its bakes require tags gpu,team-forest"), std::string::npos) << created.err;
  ASSERT_EQ(RunTool({server, "token", "create", "--data=" + data.string(), "--role=worker", "--name=node-1"}).exit_code,
            0);
  const ToolRun list = RunTool({server, "token", "list", "--data=" + data.string()});
  ASSERT_EQ(list.exit_code, 0) << list.err;
  std::map<std::string, std::string> last_column;
  std::istringstream lines(list.out);
  for (std::string line; std::getline(lines, line);) {
    last_column[line.substr(0, line.find(' '))] = line.substr(line.rfind(' ') + 1);
  }
  EXPECT_EQ(last_column["NAME"], "REQUIRED_TAGS") << list.out;
  EXPECT_EQ(last_column["forest-ci"], "gpu,team-forest") << list.out;
  EXPECT_EQ(last_column["node-1"], "-") << list.out;
}

TEST(AuthServerMode, NoneIsRefusedOffLoopbackAndTokenIsTheDefaultThere) {
  const fs::path data = NewTempDir("auth_mode");
  const std::string server = (BinaryDir() / "impostor-server").string();
  const ToolRun none = RunTool({server, "--listen=0.0.0.0:0", "--data=" + data.string(), "--auth=none"}, kStartTimeout);
  EXPECT_EQ(none.exit_code, 2);
  EXPECT_NE(none.err.find("not a loopback address"), std::string::npos) << none.err;
  // Off loopback the default is token: an anonymous call is refused.
  ServerProcess open_farm(0, data, "0.0.0.0:0");
  EXPECT_TRUE(open_farm.process().WaitForLog("auth=token"));
  grpc::ChannelArguments args;
  args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  auto channel = grpc::CreateCustomChannel(open_farm.address(), grpc::InsecureChannelCredentials(), args);
  auto ctx = ContextWithin();
  v1::LeaseJobRequest lease;
  lease.set_worker_id("intruder");
  v1::LeaseJobResponse response;
  EXPECT_EQ(v1::WorkerService::NewStub(channel)->LeaseJob(ctx.get(), lease, &response).error_code(),
            StatusCode::UNAUTHENTICATED);
}

}  // namespace
}  // namespace impostor::testing
