// Graceful shutdown with real processes: SIGTERM to the server ends streams
// and long polls with UNAVAILABLE, exits 0 and keeps every job; SIGTERM to a
// busy worker hands its job to another worker at once (no lease timeout);
// --local-workers drain on server shutdown; a worker gives up on a server
// that stays away past --max-outage-seconds.
#include <signal.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "tests/integration/farm_processes.h"
#include "tests/support/server_process.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::AssetsDir;

constexpr char kPauseEnv[] = "IMPOSTOR_WORKER_TEST_PAUSE_FILE";

bool PausedAtRender(const v1::Job& j) { return j.state() == v1::JOB_STATE_RUNNING && j.stage() == "render"; }

bool StartsWith(const std::string& s, const std::string& prefix) { return s.rfind(prefix, 0) == 0; }

bool ExitedZero(int wait_status) { return WIFEXITED(wait_status) && WEXITSTATUS(wait_status) == 0; }

TEST(GracefulShutdown, ServerSigtermEndsStreamsWithUnavailableExitsZeroAndKeepsJobs) {
  auto server = std::make_unique<testing::ServerProcess>(/*local_workers=*/0);
  const fs::path data = server->data_dir();
  const std::string address = server->address();

  // A job leased by a hand-driven worker: the queue is empty, so the long
  // poll below waits.
  const std::string bytes = "mesh bytes no worker will bake";
  const v1::Digest digest = testing::DigestOf(bytes);
  ASSERT_TRUE(testing::UploadBytes(server->assets(), bytes, digest).ok());
  v1::SubmitBakeRequest submit;
  submit.mutable_mesh()->mutable_entry()->set_path("model.glb");
  *submit.mutable_mesh()->mutable_entry()->mutable_digest() = digest;
  submit.set_request_id("shutdown-test-submit-1");
  v1::SubmitBakeResponse submitted;
  {
    grpc::ClientContext ctx;
    ASSERT_TRUE(server->bake().SubmitBake(&ctx, submit, &submitted).ok());
  }
  v1::LeaseJobResponse leased;
  {
    grpc::ClientContext ctx;
    v1::LeaseJobRequest lease;
    lease.set_worker_id("hand-worker");
    ASSERT_TRUE(server->workers().LeaseJob(&ctx, lease, &leased).ok());
    ASSERT_EQ(leased.job().job_id(), submitted.job_id());
  }

  // A watcher streaming and a worker long-polling when the signal comes.
  grpc::ClientContext watch_ctx;
  watch_ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
  v1::WatchJobRequest watch;
  watch.set_job_id(submitted.job_id());
  auto watcher = server->bake().WatchJob(&watch_ctx, watch);
  v1::Job seen;
  ASSERT_TRUE(watcher->Read(&seen));
  EXPECT_EQ(seen.state(), v1::JOB_STATE_RUNNING);
  grpc::Status long_poll;
  std::thread poller([&] {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
    v1::LeaseJobRequest lease;
    lease.set_worker_id("idle-worker");
    lease.set_wait_seconds(60);
    v1::LeaseJobResponse response;
    long_poll = server->workers().LeaseJob(&ctx, lease, &response);
  });

  const auto signalled = std::chrono::steady_clock::now();
  const int status = server->process().Terminate();
  std::printf("shutdown: the server exited %.2f s after SIGTERM\n",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - signalled).count());
  EXPECT_TRUE(ExitedZero(status)) << "wait status " << status;
  while (watcher->Read(&seen)) {
  }
  const grpc::Status watch_end = watcher->Finish();
  EXPECT_EQ(watch_end.error_code(), grpc::StatusCode::UNAVAILABLE) << watch_end.error_message();
  EXPECT_NE(watch_end.error_message().find("shutting down"), std::string::npos) << watch_end.error_message();
  poller.join();
  // The poll may reach the server before the signal (the scheduler answers
  // UNAVAILABLE, see LeaseLossTest), while gRPC shuts down (CANCELLED) or
  // after (UNAVAILABLE): in every case it must neither hang to its deadline
  // nor come back empty-handed as if all were well.
  EXPECT_NE(long_poll.error_code(), grpc::StatusCode::OK);
  EXPECT_NE(long_poll.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED) << long_poll.error_message();

  // The job is all there after a restart, the retried submit finds it, and
  // the old lease can still be handed back.
  server = std::make_unique<testing::ServerProcess>(0, data, address);
  const v1::Job after = testing::GetJob(server->bake(), submitted.job_id());
  EXPECT_EQ(after.state(), v1::JOB_STATE_RUNNING);
  EXPECT_EQ(after.worker_id(), "hand-worker");
  {
    grpc::ClientContext ctx;
    v1::SubmitBakeResponse again;
    ASSERT_TRUE(server->bake().SubmitBake(&ctx, submit, &again).ok());
    EXPECT_EQ(again.job_id(), submitted.job_id()) << "a retried submit must not create a second job";
  }
  {
    grpc::ClientContext ctx;
    v1::ReleaseJobRequest release;
    release.set_job_id(leased.job().job_id());
    release.set_lease_id(leased.job().lease_id());
    release.set_reason("test");
    v1::ReleaseJobResponse response;
    const grpc::Status s = server->workers().ReleaseJob(&ctx, release, &response);
    EXPECT_TRUE(s.ok()) << s.error_message();
  }
  const v1::Job released = testing::GetJob(server->bake(), submitted.job_id());
  EXPECT_EQ(released.state(), v1::JOB_STATE_QUEUED);
  EXPECT_EQ(released.attempts(), 0u);
}

// The store loses a result's blobs between the worker's upload and its
// CompleteJob (eviction with --store-eviction-grace-seconds 0 can): the
// worker uploads them again and completes under the same lease, instead of
// leaving the job to wait out its lease and bake again.
TEST(WorkerOutage, AResultWhoseBlobsWentBeforeCompletionIsUploadedAgain) {
  testing::ServerProcess server(/*local_workers=*/0);
  const fs::path pause = testing::NewTempDir("blobs_gone") / "pause";
  std::ofstream(pause) << "complete\n";
  auto worker = testing::StartWorker(server.address(), "uploader", {}, {{kPauseEnv, pause.string()}});
  const v1::MeshInput mesh = testing::UploadGlb(server.assets(), AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb");
  const v1::SubmitBakeResponse job = testing::SubmitSmall(server.bake(), mesh);
  const v1::Job uploaded = testing::WatchUntil(server.bake(), job.job_id(), [](const v1::Job& j) {
    return j.state() == v1::JOB_STATE_RUNNING && j.stage() == "uploaded";
  });
  ASSERT_EQ(uploaded.stage(), "uploaded") << uploaded.DebugString();
  // Every blob but the mesh: the result's maps and manifest.json.
  int removed = 0;
  for (const auto& entry : fs::recursive_directory_iterator(server.data_dir() / "cas")) {
    if (entry.is_regular_file() && entry.path().filename() != mesh.entry().digest().hash()) {
      fs::remove(entry.path());
      ++removed;
    }
  }
  ASSERT_GE(removed, 4) << "three maps and manifest.json were uploaded";
  fs::remove(pause);
  const v1::Job done = testing::WatchToEnd(server.bake(), job.job_id());
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
  EXPECT_EQ(done.attempts(), 1u) << "completed under its first lease";
  EXPECT_GE(worker->CountInLog("event=result_blob_gone"), 1);
}

// The default 30 s lease timeout stays: only a hand-back gets the job to
// the second worker on its first counted attempt.
TEST(GracefulShutdown, ABusyWorkerHandsItsJobToAnotherOnSigterm) {
  testing::ServerProcess server(/*local_workers=*/0);
  const fs::path pause = testing::NewTempDir("drain_handback") / "pause";
  testing::Touch(pause);
  auto draining = testing::StartWorker(server.address(), "draining", {"--drain-seconds=0"},
                                       {{kPauseEnv, pause.string()}});
  const v1::MeshInput mesh =
      testing::UploadGlb(server.assets(), AssetsDir() / "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb");
  const v1::SubmitBakeResponse job = testing::SubmitSmall(server.bake(), mesh);
  const v1::Job paused = testing::WatchUntil(server.bake(), job.job_id(), PausedAtRender);
  ASSERT_TRUE(PausedAtRender(paused));
  ASSERT_TRUE(StartsWith(paused.worker_id(), "draining-")) << paused.worker_id();
  auto rescuer = testing::StartWorker(server.address(), "rescuer", {}, {{kPauseEnv, pause.string()}});

  const auto signalled = std::chrono::steady_clock::now();
  EXPECT_TRUE(ExitedZero(draining->Terminate())) << "a draining worker exits cleanly";
  // Printed, not asserted: the figure for the README.
  std::printf("drain: the worker handed its job back and exited %.2f s after SIGTERM\n",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - signalled).count());
  fs::remove(pause);
  const v1::Job done = testing::WatchToEnd(server.bake(), job.job_id());
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
  EXPECT_TRUE(StartsWith(done.worker_id(), "rescuer-")) << done.worker_id();
  EXPECT_EQ(done.attempts(), 1u) << "the drained lease was handed back, not left to expire (that counts an attempt)";
}

TEST(GracefulShutdown, ADrainingWorkerFinishesAJobThatFitsItsBudget) {
  testing::ServerProcess server(/*local_workers=*/0);
  const fs::path pause = testing::NewTempDir("drain_finish") / "pause";
  testing::Touch(pause);
  auto worker = testing::StartWorker(server.address(), "finisher", {"--drain-seconds=600"},
                                     {{kPauseEnv, pause.string()}});
  const v1::MeshInput mesh = testing::UploadGlb(server.assets(), AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb");
  const v1::SubmitBakeResponse job = testing::SubmitSmall(server.bake(), mesh);
  ASSERT_TRUE(PausedAtRender(testing::WatchUntil(server.bake(), job.job_id(), PausedAtRender)));
  ::kill(worker->pid(), SIGTERM);
  fs::remove(pause);
  EXPECT_EQ(worker->Wait(), 0) << "the worker leaves once its job is done";
  const v1::Job done = testing::GetJob(server.bake(), job.job_id());
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
  EXPECT_TRUE(StartsWith(done.worker_id(), "finisher-")) << done.worker_id();
  EXPECT_EQ(done.attempts(), 1u);
}

TEST(GracefulShutdown, LocalWorkersHandTheirJobsBackWhenTheServerStops) {
  const fs::path pause = testing::NewTempDir("local_drain") / "pause";
  testing::Touch(pause);
  std::unique_ptr<testing::ServerProcess> server;
  {
    testing::ScopedEnv env(std::map<std::string, std::string>{{kPauseEnv, pause.string()}});  // inherited by the local workers
    server = std::make_unique<testing::ServerProcess>(1, std::vector<std::string>{"--shutdown-grace-seconds=4"});
  }
  const fs::path data = server->data_dir();
  const std::string address = server->address();
  const v1::MeshInput mesh = testing::UploadGlb(server->assets(), AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb");
  const v1::SubmitBakeResponse job = testing::SubmitSmall(server->bake(), mesh);
  const v1::Job paused = testing::WatchUntil(server->bake(), job.job_id(), PausedAtRender);
  ASSERT_TRUE(PausedAtRender(paused));
  ASSERT_TRUE(StartsWith(paused.worker_id(), "local-0-")) << paused.worker_id();

  EXPECT_TRUE(ExitedZero(server->process().Terminate()));
  server = std::make_unique<testing::ServerProcess>(0, data, address);
  const v1::Job after = testing::GetJob(server->bake(), job.job_id());
  EXPECT_EQ(after.state(), v1::JOB_STATE_QUEUED) << "handed back, not left leased to a worker that is gone";
  EXPECT_EQ(after.attempts(), 0u);
}

TEST(WorkerOutage, AWorkerGivesUpOnAServerThatStaysAway) {
  const std::string nowhere = "127.0.0.1:" + std::to_string(testing::FreeLoopbackPort());
  auto worker = testing::StartWorker(nowhere, "lonely", {"--max-outage-seconds=1"});
  EXPECT_EQ(worker->Wait(), 1);
}

TEST(WorkerOutage, OutOfRangeDrainAndOutageFlagsAreUsageErrors) {
  for (const char* flag : {"--drain-seconds=-1", "--drain-seconds=3601", "--max-outage-seconds=0",
                           "--log-level=loud"}) {
    auto worker = testing::StartWorker("127.0.0.1:1", "bad-flags", {flag});
    EXPECT_EQ(worker->Wait(), 2) << flag;
  }
}

}  // namespace
}  // namespace impostor

namespace impostor {
namespace {

TEST(ServerFlags, OutOfRangeShutdownAndPauseFlagsAreUsageErrors) {
  const fs::path data = testing::NewTempDir("server_bad_flags");
  for (const char* flag : {"--shutdown-grace-seconds=0", "--shutdown-grace-seconds=3601", "--worker-failure-limit=-1",
                           "--worker-failure-limit=1001", "--worker-pause-seconds=0"}) {
    testing::ChildProcess server({(testing::BinaryDir() / "impostor-server").string(), "--listen=127.0.0.1:0",
                                  "--data=" + data.string(), flag});
    EXPECT_EQ(server.Wait(), 2) << flag;
  }
}

// A closed terminal (SIGHUP) drains and stops the server as SIGTERM does:
// exit 0 and the shutdown lines, not death by the signal (exit 129).
TEST(ServerFlags, SighupStopsTheServerGracefully) {
  testing::ServerProcess server(/*local_workers=*/0);
  server.process().Signal(SIGHUP);
  EXPECT_EQ(server.process().Wait(), 0) << server.process().Stderr();
  EXPECT_GE(server.process().CountInLog("event=shutdown signal=" + std::to_string(SIGHUP)), 1)
      << server.process().Stderr();
  EXPECT_GE(server.process().CountInLog("event=shutdown_done"), 1) << server.process().Stderr();
}

// Values Abseil's parser accepts that the server could not use as given: a
// log level spdlog would take for "off" (a silent server), a port gRPC would
// wrap around (99999 -> 34463), and a port another server holds (gRPC's
// SO_REUSEPORT would let two farms share it and split the clients).
TEST(ServerFlags, UnusableLogLevelAndListenAddressesAreUsageErrors) {
  const fs::path data = testing::NewTempDir("server_bad_listen");
  testing::ServerProcess holder(/*local_workers=*/0);
  const struct {
    std::string flag;
    std::string message;
    std::string also = "";  // a second flag the case needs
  } cases[] = {
      {"--log-level=loud", "--log-level: \"loud\" is not a log level"},
      // Checked with --auth none too (the default on loopback).
      {"--token-cache-ttl-ms=-1", "--token-cache-ttl-ms: -1 is out of range 0..60000"},
      // The strongest-worker bound (issue 44; what it does:
      // tests/server/strong_worker_preference_test.cc).
      {"--prefer-strong-seconds=-1", "--prefer-strong-seconds: -1 is out of range 0..3600"},
      {"--prefer-strong-seconds=3601", "--prefer-strong-seconds: 3601 is out of range 0..3600"},
      // Pools and shares (issue 44; every rule: tests/server/pool_shares_test.cc).
      {"--pool-shares=gpu:team-forest=50",
       "--pool-shares: \"gpu:team-forest=50\" names pool \"gpu\", which --pools does not declare"},
      {"--pool-shares=gpu:team-forest=0", "--pool-shares: \"gpu:team-forest=0\" has a percent outside 1..100",
       "--pools=gpu"},
      {"--pool-shares=gpu:team-forest=101", "--pool-shares: \"gpu:team-forest=101\" has a percent outside 1..100",
       "--pools=gpu"},
      {"--pool-shares=gpu:team-forest=60,gpu:team-desert=41",
       "--pool-shares: \"gpu:team-desert=41\" brings the shares of pool \"gpu\" to 101 %, over 100", "--pools=gpu"},
      {"--pools=GPU", "--pools: \"GPU\" needs a pool name of 1..64 bytes of [a-z0-9._-]"},
      // Kept partial uploads (issue 44; what they do: tests/client/upload_resume_test.cc).
      {"--partial-upload-max-bytes=-1", "--partial-upload-max-bytes: -1 is below 0"},
      {"--partial-upload-max-age-seconds=0", "--partial-upload-max-age-seconds: 0 is out of range 1..604800"},
      {"--partial-upload-max-age-seconds=604801",
       "--partial-upload-max-age-seconds: 604801 is out of range 1..604800"},
      {"--listen=127.0.0.1:99999", "--listen: \"127.0.0.1:99999\" has a port that is not a number in 0..65535"},
      {"--listen=127.0.0.1", "--listen: \"127.0.0.1\" has no port"},
      {"--listen=" + holder.address(), "--listen: cannot listen on " + holder.address()},
  };
  for (const auto& c : cases) {
    std::vector<std::string> args = {(testing::BinaryDir() / "impostor-server").string(), "--listen=127.0.0.1:0",
                                     "--data=" + data.string(), "--local-workers=0", c.flag};
    if (!c.also.empty()) args.push_back(c.also);
    const testing::ToolRun run = testing::RunTool(args, std::chrono::seconds(60));
    EXPECT_EQ(run.exit_code, 2) << c.flag << "\n" << run.err;
    EXPECT_NE(run.err.find(c.message), std::string::npos) << c.flag << ": " << run.err;
    EXPECT_EQ(run.out.find("listening on"), std::string::npos) << c.flag << ": started anyway";
  }
}

}  // namespace
}  // namespace impostor

namespace impostor {
namespace {

// The server is killed while a worker is mid-bake and comes back on the same
// data directory and port: the worker's finished bake is uploaded and
// completed under its old lease (which survived the restart) instead of
// being dropped and baked again after the lease expires.
TEST(WorkerOutage, AFinishedBakeIsDeliveredOnceTheServerIsBack) {
  const std::string address = "127.0.0.1:" + std::to_string(testing::FreeLoopbackPort());
  const fs::path data = testing::NewTempDir("outage_delivery_data");
  auto server = std::make_unique<testing::ServerProcess>(0, data, address);
  const fs::path pause = testing::NewTempDir("outage_delivery") / "pause";
  testing::Touch(pause);
  // The worker's log on its stdout, to see it retry the upload.
  std::unique_ptr<testing::ChildProcess> worker;
  {
    testing::ScopedEnv env(std::map<std::string, std::string>{{kPauseEnv, pause.string()}});
    worker = std::make_unique<testing::ChildProcess>(std::vector<std::string>{
        "/bin/sh", "-c",
        "exec " + (testing::BinaryDir() / "impostor-worker").string() + " --server=" + address +
            " --name=patient --log-level=warn 2>&1"});
  }
  const v1::MeshInput mesh = testing::UploadGlb(server->assets(), AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb");
  const v1::SubmitBakeResponse job = testing::SubmitSmall(server->bake(), mesh);
  ASSERT_TRUE(PausedAtRender(testing::WatchUntil(server->bake(), job.job_id(), PausedAtRender)));

  ::kill(server->process().pid(), SIGKILL);
  server->process().Terminate();  // reaps it
  fs::remove(pause);              // the bake finishes while the server is away
  // Its first retried call is the upload (not a FailJob of the bake).
  const std::string retry = worker->ReadLineContaining("event=rpc_retry");
  ASSERT_NE(retry.find("rpc=UploadBlob"), std::string::npos) << retry;
  server = std::make_unique<testing::ServerProcess>(0, data, address);
  const v1::Job done = testing::WatchToEnd(server->bake(), job.job_id());
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
  EXPECT_EQ(done.attempts(), 1u) << "delivered under the first lease, not re-baked after it expired";
  EXPECT_TRUE(StartsWith(done.worker_id(), "patient-")) << done.worker_id();
}

}  // namespace
}  // namespace impostor
