// A full disk under the server's job database (SQLite, --data) while a
// worker completes a finished bake, with real server and worker processes:
// --data on a small tmpfs that the test mounts (as root; skipped otherwise)
// and fills with a file, the blob store (--blob-dir) elsewhere, so only the
// database's writes are refused. The worker pauses between its result
// upload and CompleteJob (the "complete" test pause), the test fills the
// disk, and lets it go on.
//  * CompleteJob's refusal carries the error reason DATABASE_FULL, and the
//    worker waits for space under the same lease instead of failing the job
//    (it used to take the refusal for a result refused for good: FailJob
//    non-retryable, itself refused, and the lease left to expire, so the
//    finished bake was baked again); once the file is removed the same
//    attempt completes;
//  * a database still full when the worker's outage budget ends fails the
//    attempt retryably once space is back: the job is queued again, not lost.
// Every wait is for a job event (WatchJob) or a worker log line.

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "tests/support/server_process.h"
#include "tests/integration/tmpfs_mount.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::ServerProcess;

constexpr char kBox[] = "props_pbr/Box/glTF-Binary/Box.glb";

// A server whose job database is on `mount_dir` and whose blob store is not.
std::unique_ptr<ServerProcess> StartServer(const fs::path& mount_dir, const std::string& name) {
  const fs::path blobs = testing::NewTempDir(name + "_blobs");
  return std::make_unique<ServerProcess>(/*local_workers=*/0, mount_dir / "data", "127.0.0.1:0",
                                         std::vector<std::string>{"--blob-dir=" + blobs.string()});
}

// Submits a small bake and waits until `worker` (paused before CompleteJob)
// has uploaded its result.
std::string SubmitAndWaitForUpload(ServerProcess& server) {
  const std::string id = testing::SubmitSmallBake(
      server.bake(), testing::UploadGlb(server.assets(), testing::AssetsDir() / kBox), /*frames=*/3, 64);
  const v1::Job uploaded = testing::WatchUntil(server.bake(), id, [](const v1::Job& j) {
    return testing::IsTerminalState(j.state()) || j.stage() == "uploaded";
  });
  EXPECT_EQ(uploaded.stage(), "uploaded") << uploaded.DebugString();
  return id;
}

TEST(DatabaseFull, ACompleteJobWaitsForSpaceAndTheSameAttemptCompletes) {
  const fs::path mount_dir = testing::NewTempDir("database_full_wait");
  IMPOSTOR_MOUNT_TMPFS_OR_SKIP(mount_dir, tmpfs, "the server's job database");
  auto server = StartServer(mount_dir, "database_full_wait");
  const fs::path pause = testing::NewTempDir("database_full_wait_pause") / "pause";
  std::ofstream(pause) << "complete";
  auto worker = testing::StartWorker(server->address(), {"--name=patient"},
                                     {"IMPOSTOR_WORKER_TEST_PAUSE_FILE=" + pause.string()});
  const std::string id = SubmitAndWaitForUpload(*server);
  ASSERT_FALSE(HasFailure());

  const fs::path filler = mount_dir / "filler";
  testing::FillDisk(filler);
  fs::remove(pause);
  // SQLite's words for SQLITE_FULL, on the line that starts the wait or on
  // the one that gives the result up.
  EXPECT_TRUE(worker->WaitForLog("database or disk is full")) << "CompleteJob was never refused";
  EXPECT_EQ(worker->CountInLog("event=job_done"), 0) << "the worker gave its result up for a full database";
  EXPECT_EQ(worker->CountInLog("event=job_failed"), 0) << "the job was failed for a full database";
  EXPECT_EQ(worker->CountInLog("event=database_full rpc=CompleteJob "), 1)
      << "the worker did not say it waits for space";
  {
    v1::GetJobRequest request;
    request.set_job_id(id);
    v1::Job waiting;
    auto ctx = testing::ContextWithin();
    ASSERT_TRUE(server->bake().GetJob(ctx.get(), request, &waiting).ok());
    EXPECT_EQ(waiting.state(), v1::JOB_STATE_RUNNING) << waiting.DebugString();
  }

  fs::remove(filler);
  const v1::Job done = testing::WatchToEnd(server->bake(), id);
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.DebugString();
  EXPECT_EQ(done.attempts(), 1u) << "the finished bake was baked again";
  EXPECT_TRUE(worker->WaitForLog("event=database_full_end rpc=CompleteJob ")) << "no line saying the wait ended";
  EXPECT_EQ(worker->CountInLog("ok=false"), 0) << "the worker said its result was lost";
}

TEST(DatabaseFull, ADatabaseFullPastTheOutageBudgetRequeuesTheJob) {
  const fs::path mount_dir = testing::NewTempDir("database_full_budget");
  IMPOSTOR_MOUNT_TMPFS_OR_SKIP(mount_dir, tmpfs, "the server's job database");
  auto server = StartServer(mount_dir, "database_full_budget");
  const fs::path pause = testing::NewTempDir("database_full_budget_pause") / "pause";
  std::ofstream(pause) << "complete";
  auto worker = testing::StartWorker(server->address(), {"--name=brief", "--max-outage-seconds=3"},
                                     {"IMPOSTOR_WORKER_TEST_PAUSE_FILE=" + pause.string()});
  const std::string id = SubmitAndWaitForUpload(*server);
  ASSERT_FALSE(HasFailure());

  const fs::path filler = mount_dir / "filler";
  testing::FillDisk(filler);
  fs::remove(pause);
  // CompleteJob given up (after the budget, still full): space comes back
  // while the worker's FailJob waits for it.
  ASSERT_TRUE(worker->WaitForLog("event=job_done")) << "CompleteJob never ended";
  fs::remove(filler);

  // Queued again and baked once more, the first attempt not counted (the
  // only worker takes it back at once, so the queued state may pass unseen).
  const v1::Job done = testing::WatchToEnd(server->bake(), id);
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << "not queued again: " << done.DebugString();
  EXPECT_EQ(done.attempts(), 1u) << "the server's full disk cost the job an attempt";
  ASSERT_EQ(done.attempt_history_size(), 2);
  const v1::JobAttempt& first = done.attempt_history(0);
  EXPECT_EQ(first.outcome(), v1::JobAttempt::OUTCOME_FAILED) << first.DebugString();
  EXPECT_NE(first.message().find("job database stayed full"), std::string::npos) << first.message();
  // Said as the server's state, so it is not held against the worker.
  EXPECT_EQ(worker->CountInLog("event=job_failed "), 1) << worker->Stderr();
  EXPECT_EQ(worker->CountInLog("code=14 retryable=true reason=DATABASE_FULL"), 1) << worker->Stderr();
  EXPECT_TRUE(server->process().WaitForLog("worker_fault=false")) << "the server held it against the worker";
}

}  // namespace
}  // namespace impostor
