// Poison jobs with real processes: a mesh that kills every worker that
// bakes it (the test-only IMPOSTOR_WORKER_TEST_CRASH_ON switch raises
// SIGSEGV at its render stage) fails after --max-attempts with an error
// that says the workers died on it, and other jobs keep baking. Short lease
// timeouts (5 s, five heartbeats), no sleeps: each step waits for a process
// exit or a job state.
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "tests/integration/farm_processes.h"
#include "tests/support/server_process.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::AssetsDir;

constexpr char kCrashEnv[] = "IMPOSTOR_WORKER_TEST_CRASH_ON";
constexpr int kSigsegvExit = 128 + 11;

fs::path Box() { return AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb"; }
// Other bytes than Box: the cache key ignores file names, so the same bytes
// under another name would share the poisoned bake.
fs::path OtherBox() { return AssetsDir() / "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb"; }

bool Terminal(const v1::Job& j) {
  return j.state() == v1::JOB_STATE_SUCCEEDED || j.state() == v1::JOB_STATE_FAILED ||
         j.state() == v1::JOB_STATE_CANCELLED;
}

TEST(PoisonJob, AJobThatKillsEveryWorkerFailsSayingSoAndOthersStillBake) {
  testing::ServerProcess server(/*local_workers=*/0, {"--lease-timeout-s=5", "--max-attempts=2"});
  const v1::MeshInput poison = testing::UploadGlb(server.assets(), Box(), "Poison.glb");
  const v1::SubmitBakeResponse job = testing::SubmitSmall(server.bake(), poison);
  // Each worker leases it, dies at its render stage; the lease expires and
  // the next worker gets it.
  for (int i = 1; i <= 2; ++i) {
    auto worker = testing::StartWorker(server.address(), "victim" + std::to_string(i), {},
                                       {{kCrashEnv, "Poison.glb"}});
    EXPECT_EQ(worker->Wait(), kSigsegvExit) << "victim " << i;
  }
  const v1::Job failed = testing::WatchToEnd(server.bake(), job.job_id());
  EXPECT_EQ(failed.state(), v1::JOB_STATE_FAILED);
  EXPECT_EQ(failed.attempts(), 2u);
  const std::string& message = failed.error().message();
  EXPECT_NE(message.find("lease expired 2 times: the worker died or hung while baking it (last: worker victim2-"),
            std::string::npos)
      << message;
  EXPECT_NE(message.find("at stage render)"), std::string::npos) << message;

  // The same switch is harmless for other meshes.
  auto survivor = testing::StartWorker(server.address(), "survivor", {}, {{kCrashEnv, "Poison.glb"}});
  const v1::MeshInput good = testing::UploadGlb(server.assets(), OtherBox(), "Good.glb");
  const v1::Job done = testing::WatchToEnd(server.bake(), testing::SubmitSmall(server.bake(), good).job_id());
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
}

TEST(PoisonJob, TheSupervisorNamesTheSignalAndDoesNotWaitForTheLeaseTimeout) {
  std::unique_ptr<testing::ServerProcess> server;
  {
    testing::ScopedEnv env(std::map<std::string, std::string>{{kCrashEnv, "Poison.glb"}});  // inherited by the local worker
    // A lease timeout far beyond the test: only the supervisor's report of
    // the death can end each lease.
    server = std::make_unique<testing::ServerProcess>(
        1, std::vector<std::string>{"--lease-timeout-s=3600", "--max-attempts=2"});
  }
  const v1::MeshInput poison = testing::UploadGlb(server->assets(), Box(), "Poison.glb");
  const v1::SubmitBakeResponse poisoned = testing::SubmitSmall(server->bake(), poison);
  const v1::MeshInput good = testing::UploadGlb(server->assets(), OtherBox(), "Good.glb");
  const v1::SubmitBakeResponse fine = testing::SubmitSmall(server->bake(), good);

  const v1::Job failed = testing::WatchUntil(server->bake(), poisoned.job_id(), Terminal);
  EXPECT_EQ(failed.state(), v1::JOB_STATE_FAILED);
  EXPECT_EQ(failed.attempts(), 2u);
  const std::string& message = failed.error().message();
  EXPECT_NE(message.find("lease expired 2 times: the worker died or hung while baking it (last: worker local-0-"),
            std::string::npos)
      << message;
  EXPECT_NE(message.find("the process was killed by signal 11 (SIGSEGV))"), std::string::npos) << message;
  const v1::Job done = testing::WatchUntil(server->bake(), fine.job_id(), Terminal);
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
}

}  // namespace
}  // namespace impostor

namespace impostor {
namespace {

// With --max-attempts=1 every failure is final, so the bad worker's streak
// is exactly the jobs below, one after another.
TEST(BadWorker, AWorkerThatFailsDifferentJobsInARowIsPausedAndOthersBakeTheRest) {
  testing::ServerProcess server(/*local_workers=*/0, {"--max-attempts=1", "--worker-failure-limit=2",
                                                      "--worker-pause-seconds=3600"});
  auto broken = testing::StartWorker(server.address(), "broken", {}, {{"IMPOSTOR_WORKER_TEST_FAIL_ON", "*"}});
  for (const char* name : {"a.glb", "b.glb"}) {
    // Distinct bytes per job: the same bytes would be one shared bake.
    const v1::MeshInput mesh = testing::UploadGlb(
        server.assets(), std::string(name) == "a.glb" ? Box() : OtherBox(), name);
    const v1::Job failed = testing::WatchToEnd(server.bake(), testing::SubmitSmall(server.bake(), mesh).job_id());
    EXPECT_EQ(failed.state(), v1::JOB_STATE_FAILED) << name;
    EXPECT_NE(failed.error().message().find("test fault"), std::string::npos) << failed.error().message();
    EXPECT_TRUE(failed.worker_id().rfind("broken-", 0) == 0) << failed.worker_id();
  }
  // The broken worker is paused: this job waits for a working one instead of
  // failing on the worker that is long-polling right now.
  const v1::MeshInput duck =
      testing::UploadGlb(server.assets(), AssetsDir() / "props_pbr/Duck/glTF-Binary/Duck.glb");
  const v1::SubmitBakeResponse job = testing::SubmitSmall(server.bake(), duck);
  auto healthy = testing::StartWorker(server.address(), "healthy");
  const v1::Job done = testing::WatchToEnd(server.bake(), job.job_id());
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
  EXPECT_TRUE(done.worker_id().rfind("healthy-", 0) == 0) << done.worker_id();
  EXPECT_EQ(done.attempts(), 1u);
}

}  // namespace
}  // namespace impostor
