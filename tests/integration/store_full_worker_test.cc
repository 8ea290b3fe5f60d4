// A full blob store on the server while workers upload results, with real
// server and worker processes and the server's --blob-dir on a small tmpfs
// that the test mounts (as root; skipped otherwise) and fills with a file.
//  * the upload's refusal carries the error reason STORE_FULL, and the
//    worker waits for space instead of failing the job for good (a store
//    full for 25 s used to fail 15 of 20 bakes with RESOURCE_EXHAUSTED);
//    once the file is removed the same attempt completes the bake;
//  * a store still full when the worker's outage budget ends fails the
//    attempt retryably (UNAVAILABLE): the job is queued again, not lost.
// Every wait is for a job event (WatchJob) or a worker log line.

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/server_process.h"
#include "tests/integration/tmpfs_mount.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::ServerProcess;

constexpr char kBox[] = "props_pbr/Box/glTF-Binary/Box.glb";

std::string Submit(ServerProcess& server, uint32_t resolution) {
  return testing::SubmitSmallBake(server.bake(), testing::UploadGlb(server.assets(), testing::AssetsDir() / kBox),
                                  /*frames=*/3, resolution);
}

TEST(StoreFull, AResultUploadWaitsForSpaceAndTheSameAttemptCompletes) {
  const fs::path mount_dir = testing::NewTempDir("store_full_wait");
  IMPOSTOR_MOUNT_TMPFS_OR_SKIP(mount_dir, tmpfs, "the server's blob store");
  ServerProcess server(/*local_workers=*/0, {"--blob-dir=" + (mount_dir / "blobs").string()});
  const std::string id = Submit(server, 64);  // its input is in the store
  const fs::path filler = mount_dir / "filler";
  testing::FillDisk(filler);

  auto worker = testing::StartWorker(server.address(), {"--name=waiter"});
  // The line that starts the wait is the one to wait for: the refusal's
  // message shows on it, and first on the small files' batch line.
  ASSERT_TRUE(worker->WaitForLog("event=store_full ")) << "the worker did not say it waits for space";
  ASSERT_EQ(worker->CountInLog("event=job_failed"), 0) << "the job was failed for a full store";
  ASSERT_EQ(worker->CountInLog("event=store_full "), 1);
  ASSERT_GE(worker->CountInLog("No space left on device"), 1) << "the upload was never refused";
  v1::Job waiting;
  {
    v1::GetJobRequest request;
    request.set_job_id(id);
    auto ctx = testing::ContextWithin();
    ASSERT_TRUE(server.bake().GetJob(ctx.get(), request, &waiting).ok());
  }
  EXPECT_EQ(waiting.state(), v1::JOB_STATE_RUNNING) << waiting.DebugString();

  fs::remove(filler);
  const v1::Job done = testing::WatchToEnd(server.bake(), id);
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
  EXPECT_EQ(done.attempts(), 1u);
  EXPECT_TRUE(worker->WaitForLog("event=store_full_end ")) << "no line saying the wait ended";
}

TEST(StoreFull, AStoreFullPastTheOutageBudgetRequeuesTheJob) {
  const fs::path mount_dir = testing::NewTempDir("store_full_budget");
  IMPOSTOR_MOUNT_TMPFS_OR_SKIP(mount_dir, tmpfs, "the server's blob store");
  ServerProcess server(/*local_workers=*/0, {"--blob-dir=" + (mount_dir / "blobs").string()});
  const std::string id = Submit(server, 64);
  const fs::path filler = mount_dir / "filler";
  testing::FillDisk(filler);

  auto worker = testing::StartWorker(server.address(), {"--name=brief", "--max-outage-seconds=2"});
  // The attempt fails retryably, said as the store's state (so the server
  // holds it neither against the job nor the worker); the only worker takes
  // the job back at once, so the queued state may pass unseen. Four such
  // attempts, more than --max-attempts, and the job is still alive.
  ASSERT_TRUE(worker->WaitForLog("reason=STORE_FULL", 4, std::chrono::seconds(60)))
      << "the attempts did not fail, or not as the store's state";
  EXPECT_EQ(worker->CountInLog("event=job_failed "), worker->CountInLog("reason=STORE_FULL"));
  v1::Job waiting;
  {
    v1::GetJobRequest request;
    request.set_job_id(id);
    auto ctx = testing::ContextWithin();
    ASSERT_TRUE(server.bake().GetJob(ctx.get(), request, &waiting).ok());
  }
  ASSERT_FALSE(testing::IsTerminalState(waiting.state())) << "failed for good: " << waiting.DebugString();
  ASSERT_GE(waiting.attempt_history_size(), 4);
  const v1::JobAttempt& first = waiting.attempt_history(0);
  EXPECT_EQ(first.outcome(), v1::JobAttempt::OUTCOME_FAILED);
  EXPECT_NE(first.message().find("blob store stayed full"), std::string::npos) << first.message();

  fs::remove(filler);
  const v1::Job done = testing::WatchToEnd(server.bake(), id);
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
  // The store's refusal cost the job no attempt: the bake that succeeded is
  // its first (with the default three attempts a full store outlasting three
  // budgets failed bakes for good).
  EXPECT_EQ(done.attempts(), 1u);
  EXPECT_GE(done.attempt_history_size(), 2);
}

}  // namespace
}  // namespace impostor
