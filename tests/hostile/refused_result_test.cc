// A real impostor-worker against an in-process fake server that plays the
// hostile or refusing side (issue 23):
//  * the leased job's id is a path ("../../victim"): the worker used to use
//    scratch_dir / job_id as the job's folder and remove_all it, so the id
//    chose what the worker deleted; a sentinel there must survive;
//  * CompleteJob refuses the result (RESOURCE_EXHAUSTED, as gRPC does for a
//    message over the server's limit): the worker must fail the job at once,
//    non-retryable, with the reason, instead of letting the lease time out
//    and the bake run three times.
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "tests/support/server_process.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

constexpr char kHostileJobId[] = "../../victim";

class FakeFarm final : public v1::WorkerService::Service, public v1::AssetService::Service {
 public:
  explicit FakeFarm(std::string glb) : glb_(std::move(glb)), digest_(testing::DigestOf(glb_)) {}

  grpc::Status LeaseJob(grpc::ServerContext*, const v1::LeaseJobRequest*, v1::LeaseJobResponse* response) override {
    std::unique_lock lock(mu_);
    if (leased_) {
      // Long-poll as the real server does, so an idle worker does not spin.
      changed_.wait_for(lock, std::chrono::milliseconds(200));
      return grpc::Status::OK;
    }
    leased_ = true;
    v1::LeasedJob* job = response->mutable_job();
    job->set_job_id(kHostileJobId);
    job->set_lease_id("lease-1");
    job->set_cache_key(std::string(64, 'a'));
    job->set_attempt(1);
    job->mutable_mesh()->mutable_entry()->set_path("Box.glb");
    *job->mutable_mesh()->mutable_entry()->mutable_digest() = digest_;
    job->mutable_parameters()->set_layout(v1::LAYOUT_OCTAHEDRAL);
    job->mutable_parameters()->set_frames(3);
    job->mutable_parameters()->set_resolution(64);
    return grpc::Status::OK;
  }
  grpc::Status ReportProgress(grpc::ServerContext*, const v1::ReportProgressRequest*,
                              v1::ReportProgressResponse*) override {
    return grpc::Status::OK;
  }
  grpc::Status CompleteJob(grpc::ServerContext*, const v1::CompleteJobRequest*, v1::CompleteJobResponse*) override {
    std::lock_guard lock(mu_);
    ++completes_;
    return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                        "Received message larger than max (20971520 vs. 16777216)");
  }
  grpc::Status FailJob(grpc::ServerContext*, const v1::FailJobRequest* request, v1::FailJobResponse*) override {
    std::lock_guard lock(mu_);
    failed_ = *request;
    changed_.notify_all();
    return grpc::Status::OK;
  }
  grpc::Status ReadBlob(grpc::ServerContext*, const v1::ReadBlobRequest* request,
                        grpc::ServerWriter<v1::ReadBlobResponse>* writer) override {
    if (request->digest().hash() != digest_.hash()) return grpc::Status(grpc::StatusCode::NOT_FOUND, "no such blob");
    v1::ReadBlobResponse chunk;
    chunk.set_data(glb_);
    writer->Write(chunk);
    return grpc::Status::OK;
  }
  grpc::Status UploadBlob(grpc::ServerContext*, grpc::ServerReader<v1::UploadBlobRequest>* reader,
                          v1::UploadBlobResponse*) override {
    v1::UploadBlobRequest chunk;
    while (reader->Read(&chunk)) {
    }
    return grpc::Status::OK;
  }

  // The FailJob the worker sent, once it has (or nullopt after `timeout`).
  std::optional<v1::FailJobRequest> AwaitFailJob(std::chrono::seconds timeout) {
    std::unique_lock lock(mu_);
    changed_.wait_for(lock, timeout, [&] { return failed_.has_value(); });
    return failed_;
  }
  int completes() {
    std::lock_guard lock(mu_);
    return completes_;
  }

 private:
  const std::string glb_;
  const v1::Digest digest_;
  std::mutex mu_;
  std::condition_variable changed_;
  bool leased_ = false;
  int completes_ = 0;
  std::optional<v1::FailJobRequest> failed_;
};

TEST(RefusedResult, FailedAtOnceAndTheJobIdChoosesNoFolder) {
  const fs::path box = testing::AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb";
  FakeFarm farm(testing::ReadFileBytes(box));
  int port = 0;
  grpc::ServerBuilder builder;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(static_cast<v1::WorkerService::Service*>(&farm));
  builder.RegisterService(static_cast<v1::AssetService::Service*>(&farm));
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  ASSERT_NE(port, 0);

  // scratch = DIR/a/b/scratch, so scratch / "../../victim" = DIR/a/victim.
  const fs::path dir = testing::NewTempDir("refused_result");
  const fs::path scratch = dir / "a" / "b" / "scratch";
  const fs::path victim = dir / "a" / "victim";
  fs::create_directories(victim);
  std::ofstream(victim / "sentinel") << "must survive";

  testing::ChildProcess worker({(testing::BinaryDir() / "impostor-worker").string(),
                                "--server=127.0.0.1:" + std::to_string(port), "--scratch=" + scratch.string(),
                                "--max-jobs=1", "--log-level=warn"});
  const std::optional<v1::FailJobRequest> failed = farm.AwaitFailJob(std::chrono::seconds(300));
  ASSERT_TRUE(failed.has_value()) << "the worker never failed the refused job";
  EXPECT_EQ(failed->job_id(), kHostileJobId);
  EXPECT_EQ(failed->lease_id(), "lease-1");
  EXPECT_FALSE(failed->retryable());
  EXPECT_EQ(failed->error().code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(failed->error().message().find("the server refused the result: CompleteJob: Received message larger"),
            std::string::npos)
      << failed->error().message();
  EXPECT_EQ(farm.completes(), 1);
  // --max-jobs=1: the worker leaves after this one job.
  EXPECT_EQ(worker.Wait(), 0);
  EXPECT_TRUE(fs::exists(victim / "sentinel")) << "the job id chose a folder the worker deleted";
  server->Shutdown();
}

}  // namespace
}  // namespace impostor
