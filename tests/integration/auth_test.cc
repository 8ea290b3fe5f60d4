// Identity and roles against a real impostor-server with --auth token
// (issue 14): the whole role x RPC matrix, refusals of every kind of bad
// credential, ownership of jobs, revocation and expiry seen by a running
// server, purges. Quotas, `impostor-server token` bad inputs and --auth
// modes are in auth_quota_test.cc. Results are published through
// WorkerService (no GPU); the forged-result attack with a real worker is in
// auth_bake_test.cc.
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>
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
using Clock = std::chrono::steady_clock;

// A server with tokens and one token per role; the harness's own stubs
// carry the admin token.
class AuthServer : public ::testing::Test {
 protected:
  void SetUp() override {
    server_ = std::make_unique<ServerProcess>(0, server_args_);
    for (const char* role : {"admin", "reader", "submitter", "worker"}) {
      tokens_[role] = CreateToken(server_->data_dir(), role, std::string(role) + "-1");
      ASSERT_FALSE(tokens_[role].empty());
    }
    server_->UseToken(tokens_["admin"]);
    // A plain channel: each call below sets its own authorization.
    grpc::ChannelArguments args;
    args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
    channel_ = grpc::CreateCustomChannel(server_->address(), grpc::InsecureChannelCredentials(), args);
    assets_ = v1::AssetService::NewStub(channel_);
    bake_ = v1::BakeService::NewStub(channel_);
    workers_ = v1::WorkerService::NewStub(channel_);
    admin_ = v1::AdminService::NewStub(channel_);
  }

  // AdminService.PurgeWorkerResults of `worker`, with `authorization`.
  grpc::Status Purge(const std::string& authorization, const std::string& worker,
                     v1::PurgeWorkerResultsResponse* response) {
    auto ctx = ContextWithAuthorization(authorization);
    v1::PurgeWorkerResultsRequest request;
    request.set_worker(worker);
    return admin_->PurgeWorkerResults(ctx.get(), request, response);
  }

  std::string Bearer(const std::string& role) { return "Bearer " + tokens_[role]; }

  // Uploads a unique fake model with `authorization` and submits it;
  // returns the job id ("" after a failed expectation).
  std::string SubmitFake(const std::string& authorization, uint32_t seed) {
    const std::string model = "glTF" + RandomBytes(64, seed);
    v1::SubmitBakeRequest submit;
    submit.mutable_mesh()->mutable_entry()->set_path("model.glb");
    *submit.mutable_mesh()->mutable_entry()->mutable_digest() = DigestOf(model);
    EXPECT_TRUE(Upload(authorization, model).ok());
    auto ctx = ContextWithAuthorization(authorization);
    v1::SubmitBakeResponse submitted;
    const grpc::Status s = bake_->SubmitBake(ctx.get(), submit, &submitted);
    EXPECT_TRUE(s.ok()) << s.error_message();
    return submitted.job_id();
  }

  grpc::Status Upload(const std::string& authorization, const std::string& bytes) {
    auto ctx = ContextWithAuthorization(authorization);
    v1::UploadBlobResponse response;
    auto writer = assets_->UploadBlob(ctx.get(), &response);
    v1::UploadBlobRequest chunk;
    *chunk.mutable_digest() = DigestOf(bytes);
    chunk.set_data(bytes);
    writer->Write(chunk);
    writer->WritesDone();
    return writer->Finish();
  }

  grpc::Status Read(const std::string& authorization, const v1::Digest& digest) {
    auto ctx = ContextWithAuthorization(authorization);
    v1::ReadBlobRequest request;
    *request.mutable_digest() = digest;
    auto reader = assets_->ReadBlob(ctx.get(), request);
    v1::ReadBlobResponse chunk;
    while (reader->Read(&chunk)) {
    }
    return reader->Finish();
  }

  grpc::Status Watch(const std::string& authorization, const std::string& job_id) {
    auto ctx = ContextWithAuthorization(authorization);
    v1::WatchJobRequest request;
    request.set_job_id(job_id);
    auto reader = bake_->WatchJob(ctx.get(), request);
    v1::Job job;
    while (reader->Read(&job)) {
    }
    return reader->Finish();
  }

  grpc::Status GetJob(const std::string& authorization, const std::string& job_id) {
    auto ctx = ContextWithAuthorization(authorization);
    v1::GetJobRequest request;
    request.set_job_id(job_id);
    v1::Job job;
    return bake_->GetJob(ctx.get(), request, &job);
  }

  // The job (as the admin sees it) is a real bake waiting for a worker,
  // not an answer from the cache.
  void ExpectFreshBake(const std::string& job_id) {
    auto ctx = ContextWithAuthorization(Bearer("admin"));
    v1::GetJobRequest get;
    get.set_job_id(job_id);
    v1::Job job;
    ASSERT_TRUE(bake_->GetJob(ctx.get(), get, &job).ok()) << job_id;
    EXPECT_FALSE(job.cached());
    EXPECT_EQ(job.state(), v1::JOB_STATE_QUEUED);
  }

  grpc::Status GetResult(const std::string& authorization, const std::string& key) {
    auto ctx = ContextWithAuthorization(authorization);
    v1::GetResultRequest request;
    request.set_cache_key(key);
    v1::Manifest manifest;
    return assets_->GetResult(ctx.get(), request, &manifest);
  }

  // Calls `rpc` with `authorization` and a request chosen so that an
  // allowed caller gets a known code (see kMatrix).
  grpc::Status Call(const std::string& rpc, const std::string& authorization) {
    auto ctx = ContextWithAuthorization(authorization);
    if (rpc == "FindMissingBlobs") {
      v1::FindMissingBlobsRequest request;
      *request.add_digests() = result_blob_;
      v1::FindMissingBlobsResponse response;
      return assets_->FindMissingBlobs(ctx.get(), request, &response);
    }
    if (rpc == "UploadBlob") return Upload(authorization, "matrix upload");
    if (rpc == "BatchUpdateBlobs") {
      const std::string bytes = "matrix batch upload";
      v1::BatchUpdateBlobsRequest request;
      *request.add_requests()->mutable_digest() = DigestOf(bytes);
      request.mutable_requests(0)->set_data(bytes);
      v1::BatchUpdateBlobsResponse response;
      const grpc::Status s = assets_->BatchUpdateBlobs(ctx.get(), request, &response);
      // Allowed is allowed whole: the blob's own slot is stored too.
      if (s.ok() && (response.responses_size() != 1 || response.responses(0).code() != 0)) {
        return grpc::Status(grpc::StatusCode::INTERNAL, "the batch's one blob was not stored");
      }
      return s;
    }
    if (rpc == "QueryUpload") {
      v1::QueryUploadRequest request;
      *request.mutable_digest() = result_blob_;
      v1::QueryUploadResponse response;
      return assets_->QueryUpload(ctx.get(), request, &response);
    }
    if (rpc == "ReadBlob") return Read(authorization, result_blob_);
    if (rpc == "BatchReadBlobs") {
      v1::BatchReadBlobsRequest request;
      *request.add_digests() = result_blob_;
      v1::BatchReadBlobsResponse response;
      const grpc::Status s = assets_->BatchReadBlobs(ctx.get(), request, &response);
      // Allowed is allowed whole: the blob's own slot answers it too.
      if (s.ok() && (response.blobs_size() != 1 || response.blobs(0).code() != 0)) {
        return grpc::Status(grpc::StatusCode::INTERNAL, "the batch's one blob was not served");
      }
      return s;
    }
    if (rpc == "GetResult") return GetResult(authorization, result_key_);
    if (rpc == "PinResult") {
      v1::PinResultRequest request;
      request.set_cache_key(result_key_);
      request.set_pinned(true);
      v1::PinResultResponse response;
      return assets_->PinResult(ctx.get(), request, &response);
    }
    if (rpc == "LookupBake") {
      v1::LookupBakeResponse response;
      return bake_->LookupBake(ctx.get(), v1::SubmitBakeRequest(), &response);
    }
    if (rpc == "SubmitBake") {
      v1::SubmitBakeResponse response;
      return bake_->SubmitBake(ctx.get(), v1::SubmitBakeRequest(), &response);
    }
    if (rpc == "WatchJob") return Watch(authorization, admin_job_);
    if (rpc == "GetJob") return GetJob(authorization, admin_job_);
    if (rpc == "CancelJob") {
      v1::CancelJobRequest request;
      request.set_job_id(admin_job_);
      v1::Job job;
      return bake_->CancelJob(ctx.get(), request, &job);
    }
    if (rpc == "LeaseJob") {
      v1::LeaseJobRequest request;
      request.set_worker_id("matrix");
      request.set_wait_seconds(0);
      v1::LeaseJobResponse response;
      return workers_->LeaseJob(ctx.get(), request, &response);
    }
    if (rpc == "ReportProgress") {
      v1::ReportProgressRequest request;
      request.set_job_id(admin_job_);
      request.set_lease_id("lease-none");
      v1::ReportProgressResponse response;
      return workers_->ReportProgress(ctx.get(), request, &response);
    }
    if (rpc == "CompleteJob") {
      v1::CompleteJobRequest request;
      request.set_job_id(admin_job_);
      request.set_lease_id("lease-none");
      v1::CompleteJobResponse response;
      return workers_->CompleteJob(ctx.get(), request, &response);
    }
    if (rpc == "FailJob") {
      v1::FailJobRequest request;
      request.set_job_id(admin_job_);
      request.set_lease_id("lease-none");
      v1::FailJobResponse response;
      return workers_->FailJob(ctx.get(), request, &response);
    }
    if (rpc == "ReleaseJob") {
      v1::ReleaseJobRequest request;
      request.set_job_id(admin_job_);
      request.set_lease_id("lease-none");
      v1::ReleaseJobResponse response;
      return workers_->ReleaseJob(ctx.get(), request, &response);
    }
    if (rpc == "PurgeWorkerResults") {
      v1::PurgeWorkerResultsResponse response;
      return Purge(authorization, "nobody-baked-this", &response);
    }
    ADD_FAILURE() << "no such rpc in the test: " << rpc;
    return grpc::Status::CANCELLED;
  }

  // A published result (owned by nobody: results are shared) and a finished
  // job the admin submitted and cancelled (so WatchJob ends at once).
  void MakeObjects() {
    const PublishedResult published = PublishResult(*server_, {100, 200, 300}, 14);
    result_key_ = published.key;
    result_blob_ = DigestOf(published.files.at("albedo_alpha.png"));
    admin_job_ = SubmitFake(Bearer("admin"), 1400);
    auto ctx = ContextWithAuthorization(Bearer("admin"));
    v1::CancelJobRequest cancel;
    cancel.set_job_id(admin_job_);
    v1::Job job;
    ASSERT_TRUE(bake_->CancelJob(ctx.get(), cancel, &job).ok());
  }

  // The server's flags (a derived fixture may add some before SetUp).
  std::vector<std::string> server_args_{"--auth=token"};
  std::unique_ptr<ServerProcess> server_;
  std::map<std::string, std::string> tokens_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::AssetService::Stub> assets_;
  std::unique_ptr<v1::BakeService::Stub> bake_;
  std::unique_ptr<v1::WorkerService::Stub> workers_;
  std::unique_ptr<v1::AdminService::Stub> admin_;
  std::string result_key_;
  v1::Digest result_blob_;
  std::string admin_job_;
};

using grpc::StatusCode;
constexpr StatusCode kDenied = StatusCode::PERMISSION_DENIED;

// The role x RPC matrix. `admin` is the code an allowed caller gets for the
// request Call() sends; the other columns are that same code when the role
// may make the call, PERMISSION_DENIED when it may not.
struct MatrixRow {
  const char* rpc;
  StatusCode admin;
  StatusCode reader, submitter, worker;
};
const MatrixRow kMatrix[] = {
    {"FindMissingBlobs", StatusCode::OK, kDenied, StatusCode::OK, StatusCode::OK},
    {"UploadBlob", StatusCode::OK, kDenied, StatusCode::OK, StatusCode::OK},
    // The same roles, the batch of small blobs (issue 45).
    {"BatchUpdateBlobs", StatusCode::OK, kDenied, StatusCode::OK, StatusCode::OK},
    // Who may upload may ask how far an upload got (issue 44).
    {"QueryUpload", StatusCode::OK, kDenied, StatusCode::OK, StatusCode::OK},
    // A result blob: readers and submitters read results; a worker reads
    // only the inputs of the job it holds.
    {"ReadBlob", StatusCode::OK, StatusCode::OK, StatusCode::OK, kDenied},
    // The same, each digest of a batch under ReadBlob's rule (issue 45).
    {"BatchReadBlobs", StatusCode::OK, StatusCode::OK, StatusCode::OK, kDenied},
    {"GetResult", StatusCode::OK, StatusCode::OK, StatusCode::OK, kDenied},
    {"PinResult", StatusCode::OK, kDenied, kDenied, kDenied},
    {"LookupBake", StatusCode::INVALID_ARGUMENT, StatusCode::INVALID_ARGUMENT, StatusCode::INVALID_ARGUMENT, kDenied},
    {"SubmitBake", StatusCode::INVALID_ARGUMENT, kDenied, StatusCode::INVALID_ARGUMENT, kDenied},
    // The admin's job: a submitter may follow its own jobs only.
    {"WatchJob", StatusCode::OK, kDenied, kDenied, kDenied},
    {"GetJob", StatusCode::OK, kDenied, kDenied, kDenied},
    {"CancelJob", StatusCode::OK, kDenied, kDenied, kDenied},
    {"LeaseJob", StatusCode::OK, kDenied, kDenied, StatusCode::OK},
    {"ReportProgress", StatusCode::FAILED_PRECONDITION, kDenied, kDenied, StatusCode::FAILED_PRECONDITION},
    {"CompleteJob", StatusCode::FAILED_PRECONDITION, kDenied, kDenied, StatusCode::FAILED_PRECONDITION},
    {"FailJob", StatusCode::FAILED_PRECONDITION, kDenied, kDenied, StatusCode::FAILED_PRECONDITION},
    {"ReleaseJob", StatusCode::FAILED_PRECONDITION, kDenied, kDenied, StatusCode::FAILED_PRECONDITION},
    // Administration: a worker that baked nothing purges nothing (OK).
    {"PurgeWorkerResults", StatusCode::OK, kDenied, kDenied, kDenied},
};

TEST_F(AuthServer, RoleByRpcMatrix) {
  MakeObjects();
  for (const MatrixRow& row : kMatrix) {
    for (auto [role, expected] : {std::pair<std::string, StatusCode>{"admin", row.admin}, {"reader", row.reader},
                                  {"submitter", row.submitter}, {"worker", row.worker}}) {
      const grpc::Status s = Call(row.rpc, Bearer(role));
      EXPECT_EQ(s.error_code(), expected) << row.rpc << " as " << role << ": " << s.error_message();
      if (s.error_code() == kDenied) {
        const bool blob_read = std::string(row.rpc) == "ReadBlob" || std::string(row.rpc) == "BatchReadBlobs";
        EXPECT_NE(s.error_message().find(role == "worker" && blob_read ? "inputs" : "admin"),
                  std::string::npos)
            << row.rpc << " as " << role << ": " << s.error_message();
        EXPECT_EQ(s.error_message().find(tokens_[role]), std::string::npos) << "secret echoed";
      }
    }
  }
}

// A batch is refused whole when one digest is not the token's to read, and
// the refusal names that digest's position: a reader cannot slip an input
// blob in among result blobs.
TEST_F(AuthServer, ABatchWithOneBlobTheTokenMayNotReadIsRefusedNamingIt) {
  MakeObjects();
  const std::string input = "glTF" + RandomBytes(64, 4242);
  ASSERT_TRUE(Upload(Bearer("admin"), input).ok());
  v1::BatchReadBlobsRequest request;
  *request.add_digests() = result_blob_;
  *request.add_digests() = DigestOf(input);
  for (const char* role : {"reader", "submitter"}) {
    auto ctx = ContextWithAuthorization(Bearer(role));
    v1::BatchReadBlobsResponse response;
    const grpc::Status s = assets_->BatchReadBlobs(ctx.get(), request, &response);
    EXPECT_EQ(s.error_code(), kDenied) << role << ": " << s.error_message();
    EXPECT_NE(s.error_message().find("digests[1]"), std::string::npos) << role << ": " << s.error_message();
    EXPECT_NE(s.error_message().find("result blobs only"), std::string::npos) << role << ": " << s.error_message();
    EXPECT_EQ(response.blobs_size(), 0) << role;
  }
  // The admin reads both.
  auto ctx = ContextWithAuthorization(Bearer("admin"));
  v1::BatchReadBlobsResponse response;
  const grpc::Status s = assets_->BatchReadBlobs(ctx.get(), request, &response);
  ASSERT_TRUE(s.ok()) << s.error_message();
  ASSERT_EQ(response.blobs_size(), 2);
  EXPECT_EQ(response.blobs(1).data(), input);
}

TEST_F(AuthServer, EveryRpcRefusesBadCredentialsNamingTheReason) {
  MakeObjects();
  const std::string expired = CreateToken(server_->data_dir(), "admin", "short-lived", "1s");
  const std::string revoked = CreateToken(server_->data_dir(), "admin", "revoked-1");
  ASSERT_EQ(RunTool({(BinaryDir() / "impostor-server").string(), "token", "revoke",
                     "--data=" + server_->data_dir().string(), "--name=revoked-1"})
                .exit_code,
            0);
  // Expiry is wall-clock: wait (bounded) until the server says so.
  const auto deadline = Clock::now() + std::chrono::seconds(30);
  while (GetResult("Bearer " + expired, result_key_).error_code() != StatusCode::UNAUTHENTICATED &&
         Clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  const std::string unknown = "imp_" + std::string(43, 'Q');
  struct Credential {
    const char* name;
    std::string header;
    const char* reason;
    std::string secret;  // must not appear in the message
  } credentials[] = {
      {"no token", "", "no token", ""},
      {"basic auth", "Basic YWRtaW46YWRtaW4=", "malformed authorization", "YWRtaW46YWRtaW4="},
      {"malformed token", "Bearer hunter2", "malformed token", "hunter2"},
      {"unknown token", "Bearer " + unknown, "unknown token", unknown},
      {"expired token", "Bearer " + expired, "expired token: 'short-lived'", expired},
      {"revoked token", "Bearer " + revoked, "revoked token: 'revoked-1'", revoked},
  };
  for (const Credential& c : credentials) {
    for (const MatrixRow& row : kMatrix) {
      const grpc::Status s = Call(row.rpc, c.header);
      EXPECT_EQ(s.error_code(), StatusCode::UNAUTHENTICATED) << row.rpc << " with " << c.name << ": "
                                                            << s.error_message();
      EXPECT_NE(s.error_message().find(c.reason), std::string::npos) << row.rpc << " with " << c.name << ": "
                                                                     << s.error_message();
      if (!c.secret.empty()) {
        EXPECT_EQ(s.error_message().find(c.secret), std::string::npos) << row.rpc << " with " << c.name;
      }
    }
  }
  // Audit: refusals are logged, secrets never.
  const std::string log = server_->process().Stderr();
  EXPECT_NE(log.find("event=auth_refused"), std::string::npos);
  for (const auto& [role, secret] : tokens_) EXPECT_EQ(log.find(secret), std::string::npos) << role;
  EXPECT_EQ(log.find(expired), std::string::npos);
}

TEST_F(AuthServer, SubmittersSeeTheirOwnJobsOnly) {
  const std::string other = CreateToken(server_->data_dir(), "submitter", "other-artist");
  const std::string mine = SubmitFake(Bearer("submitter"), 1401);
  ASSERT_FALSE(mine.empty());
  EXPECT_TRUE(GetJob(Bearer("submitter"), mine).ok());
  EXPECT_TRUE(GetJob(Bearer("admin"), mine).ok());
  const grpc::Status s = GetJob("Bearer " + other, mine);
  EXPECT_EQ(s.error_code(), StatusCode::PERMISSION_DENIED) << s.error_message();
  EXPECT_NE(s.error_message().find("was not submitted by token 'other-artist'"), std::string::npos)
      << s.error_message();
  EXPECT_EQ(Watch("Bearer " + other, mine).error_code(), StatusCode::PERMISSION_DENIED);
  // Unknown jobs stay NOT_FOUND for everyone allowed to ask.
  EXPECT_EQ(GetJob(Bearer("submitter"), "job-nonexistent").error_code(), StatusCode::NOT_FOUND);

  // A worker reads the inputs of the job it holds, and nothing else.
  auto ctx = ContextWithAuthorization(Bearer("worker"));
  v1::LeaseJobRequest lease;
  lease.set_worker_id("w");
  v1::LeaseJobResponse leased;
  ASSERT_TRUE(workers_->LeaseJob(ctx.get(), lease, &leased).ok());
  ASSERT_TRUE(leased.has_job());
  EXPECT_TRUE(Read(Bearer("worker"), leased.job().mesh().entry().digest()).ok());
  const std::string other_worker = CreateToken(server_->data_dir(), "worker", "worker-2");
  EXPECT_EQ(Read("Bearer " + other_worker, leased.job().mesh().entry().digest()).error_code(),
            StatusCode::PERMISSION_DENIED);
  // Readers and submitters never read inputs (unreleased meshes).
  EXPECT_EQ(Read(Bearer("reader"), leased.job().mesh().entry().digest()).error_code(), StatusCode::PERMISSION_DENIED);
  EXPECT_EQ(Read(Bearer("submitter"), leased.job().mesh().entry().digest()).error_code(),
            StatusCode::PERMISSION_DENIED);
}

TEST_F(AuthServer, RevocationTakesEffectOnARunningServerWithinSeconds) {
  MakeObjects();
  const std::string token = CreateToken(server_->data_dir(), "reader", "game-client");
  ASSERT_TRUE(GetResult("Bearer " + token, result_key_).ok());  // now cached by the server
  const ToolRun revoke = RunTool({(BinaryDir() / "impostor-server").string(), "token", "revoke",
                                  "--data=" + server_->data_dir().string(), "--name=game-client"});
  ASSERT_EQ(revoke.exit_code, 0) << revoke.err;
  // The promise is "within a few seconds" (the server re-validates every 2 s).
  const auto deadline = Clock::now() + std::chrono::seconds(10);
  grpc::Status s;
  while ((s = GetResult("Bearer " + token, result_key_)).ok() && Clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(s.error_code(), StatusCode::UNAUTHENTICATED) << s.error_message();
  EXPECT_NE(s.error_message().find("revoked token: 'game-client'"), std::string::npos) << s.error_message();
  // `token list` shows it revoked, with a last-used time, and no secrets.
  const ToolRun list = RunTool({(BinaryDir() / "impostor-server").string(), "token", "list",
                                "--data=" + server_->data_dir().string()});
  ASSERT_EQ(list.exit_code, 0) << list.err;
  EXPECT_NE(list.out.find("game-client"), std::string::npos);
  EXPECT_NE(list.out.find("revoked"), std::string::npos);
  EXPECT_EQ(list.out.find("imp_"), std::string::npos) << list.out;
}

TEST_F(AuthServer, AuditLinesNameTokenRoleRpcAndOutcome) {
  MakeObjects();
  EXPECT_EQ(Call("PinResult", Bearer("reader")).error_code(), kDenied);
  EXPECT_TRUE(server_->process().WaitForLog("event=audit token=\"reader-1\" role=reader rpc=PinResult"));
  EXPECT_TRUE(server_->process().WaitForLog("event=audit token=\"admin-1\" role=admin rpc=CancelJob object=\"" +
                                            admin_job_ + "\" outcome=OK"));
  EXPECT_TRUE(server_->process().WaitForLog("event=audit token=\"admin-1\" role=admin rpc=SubmitBake"));
}

TEST_F(AuthServer, PurgeByWorkerDropsWhatItBakedSoTheKeysBakeAgain) {
  for (const char* node : {"node-a", "node-b"}) tokens_[node] = CreateToken(server_->data_dir(), "worker", node);
  // One result baked by each worker: the admin submits, the worker completes.
  std::map<std::string, PublishedResult> baked;
  uint32_t seed = 1410;
  for (const char* node : {"node-a", "node-b"}) {
    ASSERT_FALSE(SubmitFake(Bearer("admin"), seed).empty());
    server_->UseToken(tokens_[node]);
    baked[node] = CompleteNextJob(*server_, {100, 100, 100}, seed);
    ++seed;
  }
  server_->UseToken(tokens_["admin"]);
  {
    auto ctx = ContextWithAuthorization(Bearer("reader"));
    v1::GetResultRequest request;
    request.set_cache_key(baked["node-b"].key);
    v1::Manifest manifest;
    ASSERT_TRUE(assets_->GetResult(ctx.get(), request, &manifest).ok());
    EXPECT_EQ(manifest.baked_by(), "node-b");
  }

  // Purged while the server runs.
  const std::string server_bin = (BinaryDir() / "impostor-server").string();
  const ToolRun purge =
      RunTool({server_bin, "purge", "--worker", "node-a", "--data", server_->data_dir().string()}, kStartTimeout);
  ASSERT_EQ(purge.exit_code, 0) << purge.err;
  EXPECT_EQ(purge.out, baked["node-a"].key + "\n");
  EXPECT_NE(purge.err.find("dropped 1 result(s) baked by 'node-a'"), std::string::npos) << purge.err;

  EXPECT_EQ(GetResult(Bearer("reader"), baked["node-a"].key).error_code(), StatusCode::NOT_FOUND);
  EXPECT_TRUE(GetResult(Bearer("reader"), baked["node-b"].key).ok());
  // Its blobs are no longer a result's: readers cannot fetch them.
  EXPECT_EQ(Read(Bearer("reader"), DigestOf(baked["node-a"].files.at("albedo_alpha.png"))).error_code(),
            StatusCode::PERMISSION_DENIED);
  // The same request bakes again instead of answering from the cache.
  ExpectFreshBake(SubmitFake(Bearer("admin"), 1410));

  struct Case {
    const char* name;
    std::vector<std::string> args;
    const char* message;
  } cases[] = {
      {"no worker", {"purge", "--data", server_->data_dir().string()}, "--worker: required"},
      {"bad worker", {"purge", "--worker", "a/b", "--data", server_->data_dir().string()}, "--worker:"},
      {"no data", {"purge", "--worker", "node-a"}, "--data: required"},
      {"not a data dir", {"purge", "--worker", "node-a", "--data", "/nonexistent"}, "holds no job database"},
      {"unknown flag", {"purge", "--worker", "node-a", "--all"}, "unknown argument \"--all\""},
  };
  for (const Case& c : cases) {
    std::vector<std::string> argv = {server_bin};
    argv.insert(argv.end(), c.args.begin(), c.args.end());
    const ToolRun run = RunTool(argv, kStartTimeout);
    EXPECT_EQ(run.exit_code, 2) << c.name << ": " << run.err;
    EXPECT_NE(run.err.find(c.message), std::string::npos) << c.name << ": " << run.err;
  }

  // The admin RPC drops results too, but within the eviction grace (10 min
  // by default) their blobs stay: a bake about to complete may have found
  // them present.
  v1::PurgeWorkerResultsResponse rpc;
  const grpc::Status s = Purge(Bearer("admin"), "node-b", &rpc);
  ASSERT_TRUE(s.ok()) << s.error_message();
  ASSERT_EQ(rpc.cache_keys_size(), 1);
  EXPECT_EQ(rpc.cache_keys(0), baked["node-b"].key);
  EXPECT_EQ(rpc.blobs_removed(), 0);
  EXPECT_EQ(rpc.blobs_kept(), 4) << "three maps and the stamped manifest.json";
  EXPECT_EQ(GetResult(Bearer("reader"), baked["node-b"].key).error_code(), StatusCode::NOT_FOUND);
}

// A server whose eviction grace is 0, so a purge may delete blobs at once.
class AuthServerNoGrace : public AuthServer {
 protected:
  AuthServerNoGrace() { server_args_.push_back("--store-eviction-grace-seconds=0"); }

  fs::path CasPath(const std::string& bytes) const {
    const std::string hash = DigestOf(bytes).hash();
    return server_->data_dir() / "cas" / hash.substr(0, 2) / hash;
  }
};

TEST_F(AuthServerNoGrace, PurgeRpcDropsResultsAndTheBlobsOnlyTheyUsed) {
  for (const char* node : {"node-a", "node-b"}) tokens_[node] = CreateToken(server_->data_dir(), "worker", node);
  // node-a bakes two results; node-b one whose maps are byte for byte those
  // of node-a's second (same map seed), so those blobs are shared.
  struct Bake {
    const char* node;
    uint32_t model_seed, map_seed;
  } bakes[] = {{"node-a", 1420, 1420}, {"node-a", 1421, 1430}, {"node-b", 1422, 1430}};
  std::vector<PublishedResult> results;
  for (const Bake& b : bakes) {
    ASSERT_FALSE(SubmitFake(Bearer("admin"), b.model_seed).empty());
    server_->UseToken(tokens_[b.node]);
    results.push_back(CompleteNextJob(*server_, {100, 200, 300}, b.map_seed));
    server_->UseToken(tokens_["admin"]);
  }
  // The stamped manifest.json, as `impostor fetch` installs it, names the
  // worker token (the worker's own text did not).
  const fs::path token_file = server_->data_dir().parent_path() / (server_->data_dir().filename().string() + ".admin");
  {
    std::ofstream(token_file) << tokens_["admin"] << "\n";
  }
  const fs::path out = server_->data_dir().parent_path() / (server_->data_dir().filename().string() + "-fetch");
  const std::string cli = (BinaryDir() / "impostor").string();
  const ToolRun fetch = RunTool({cli, "fetch", results[2].key, "--out", out.string(), "--server", server_->address(),
                                 "--token-file", token_file.string()},
                                kStartTimeout);
  ASSERT_EQ(fetch.exit_code, 0) << fetch.err;
  // A token file that cannot be used is the caller's mistake, refused before
  // connecting: exit 2 (3 would tell CI to retry).
  for (const std::string& bad : {(out / "no-such-token").string(), out.string()}) {
    const ToolRun refused =
        RunTool({cli, "status", "job-1", "--server", server_->address(), "--token-file", bad}, kStartTimeout);
    EXPECT_EQ(refused.exit_code, 2) << bad << ": " << refused.err;
    EXPECT_NE(refused.err.find("--token-file: "), std::string::npos) << refused.err;
  }
  const std::string manifest = ReadFileBytes(out / "manifest.json");
  EXPECT_NE(manifest.find("\"baked_by\": \"node-b\""), std::string::npos) << manifest;
  EXPECT_EQ(results[2].files.at("manifest.json").find("baked_by"), std::string::npos);
  EXPECT_EQ(ReadFileBytes(out / "albedo_alpha.png"), results[2].files.at("albedo_alpha.png"));

  v1::PurgeWorkerResultsResponse purged;
  grpc::Status s = Purge(Bearer("admin"), "node-a", &purged);
  ASSERT_TRUE(s.ok()) << s.error_message();
  std::set<std::string> keys(purged.cache_keys().begin(), purged.cache_keys().end());
  EXPECT_EQ(keys, (std::set<std::string>{results[0].key, results[1].key}));
  // Removed: the first result's three maps and both stamped manifests; kept:
  // the three maps node-b's result lists too.
  EXPECT_EQ(purged.blobs_removed(), 5);
  EXPECT_EQ(purged.blobs_kept(), 3);
  // 100 + 200 + 300 bytes of maps and the two manifests, a few bytes longer
  // stamped than as the worker wrote them.
  const int64_t unstamped = 600 + static_cast<int64_t>(results[0].files.at("manifest.json").size() +
                                                       results[1].files.at("manifest.json").size());
  EXPECT_GT(purged.bytes_freed(), unstamped);
  EXPECT_LT(purged.bytes_freed(), unstamped + 2 * 64);
  for (const char* map : {"albedo_alpha.png", "normal_depth.png", "orm.png"}) {
    EXPECT_FALSE(fs::exists(CasPath(results[0].files.at(map)))) << map << " of a purged result stayed";
    EXPECT_TRUE(fs::exists(CasPath(results[1].files.at(map)))) << map << " that node-b's result lists was deleted";
  }
  EXPECT_EQ(GetResult(Bearer("reader"), results[0].key).error_code(), StatusCode::NOT_FOUND);
  EXPECT_EQ(GetResult(Bearer("reader"), results[1].key).error_code(), StatusCode::NOT_FOUND);
  EXPECT_TRUE(GetResult(Bearer("reader"), results[2].key).ok());
  EXPECT_TRUE(Read(Bearer("reader"), DigestOf(results[2].files.at("orm.png"))).ok());
  EXPECT_TRUE(server_->process().WaitForLog("event=audit token=\"admin-1\" role=admin rpc=PurgeWorkerResults "
                                            "object=\"worker=node-a results=2 blobs_removed=5\" outcome=OK"));

  // A second purge finds nothing; the purged key bakes afresh.
  s = Purge(Bearer("admin"), "node-a", &purged);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(purged.cache_keys_size(), 0);
  ExpectFreshBake(SubmitFake(Bearer("admin"), 1420));
  server_->UseToken(tokens_["node-b"]);
  const PublishedResult rebaked = CompleteNextJob(*server_, {100, 200, 300}, 1420);
  server_->UseToken(tokens_["admin"]);
  EXPECT_EQ(rebaked.key, results[0].key);
  {
    auto ctx = ContextWithAuthorization(Bearer("reader"));
    v1::GetResultRequest request;
    request.set_cache_key(rebaked.key);
    v1::Manifest manifest;
    ASSERT_TRUE(assets_->GetResult(ctx.get(), request, &manifest).ok());
    EXPECT_EQ(manifest.baked_by(), "node-b");
  }
  EXPECT_TRUE(fs::exists(CasPath(results[0].files.at("albedo_alpha.png")))) << "the fresh bake uploaded it again";

  // Bad input names the field and its limit.
  struct Case {
    const char* name;
    std::string worker;
    const char* message;
  } cases[] = {
      {"empty", "", "worker: must be 1..64 characters, got 0"},
      {"too long", std::string(65, 'w'), "worker: must be 1..64 characters, got 65"},
      {"bad character", "node/a", "worker: only letters, digits"},
  };
  for (const Case& c : cases) {
    s = Purge(Bearer("admin"), c.worker, &purged);
    EXPECT_EQ(s.error_code(), StatusCode::INVALID_ARGUMENT) << c.name;
    EXPECT_NE(s.error_message().find(c.message), std::string::npos) << c.name << ": " << s.error_message();
  }

  // The CLI: `impostor admin purge`, exit codes and JSON like the others.
  const std::vector<std::string> conn = {"--server", server_->address(), "--token-file", token_file.string()};
  auto admin_purge = [&](std::vector<std::string> args, std::vector<std::string> env = {}) {
    std::vector<std::string> argv = {cli, "admin", "purge"};
    argv.insert(argv.end(), args.begin(), args.end());
    return RunTool(argv, kStartTimeout, std::move(env));
  };
  std::vector<std::string> args = conn;
  args.insert(args.end(), {"--worker", "node-b", "--json"});
  ToolRun run = admin_purge(args);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("\"worker\":\"node-b\""), std::string::npos) << run.out;
  EXPECT_NE(run.out.find(results[2].key), std::string::npos) << run.out;
  EXPECT_NE(run.out.find(rebaked.key), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("\"error\":null"), std::string::npos) << run.out;
  run = admin_purge({"--server", server_->address(), "--worker", "node-b"}, {"IMPOSTOR_TOKEN=" + tokens_["reader"]});
  EXPECT_EQ(run.exit_code, 1) << run.err;  // a refusal, not worth retrying
  EXPECT_NE(run.err.find("PERMISSION_DENIED"), std::string::npos) << run.err;
  run = admin_purge({"--server", server_->address(), "--worker", std::string(65, 'w')},
                    {"IMPOSTOR_TOKEN=" + tokens_["admin"]});
  EXPECT_EQ(run.exit_code, 1) << run.err;
  EXPECT_NE(run.err.find("worker: must be 1..64 characters"), std::string::npos) << run.err;
  run = admin_purge(conn);
  EXPECT_EQ(run.exit_code, 2) << run.err;
  EXPECT_NE(run.err.find("--worker: required"), std::string::npos) << run.err;
}

}  // namespace
}  // namespace impostor::testing
