// A job that one worker fails retryably for a reason of its own is baked by
// another worker, with real server and worker processes at the server's
// default flags (--retry-elsewhere-seconds 60, --worker-failure-limit 3).
// The "tight" worker's host memory is made small with
// IMPOSTOR_WORKER_TEST_HOST_MEMORY (worker/test_faults.h): it has the total
// for the bake but not the free memory right now, so it fails the job with
// UNAVAILABLE ("another worker may take it"). The "roomy" worker is busy,
// held at the render stage of another job by IMPOSTOR_WORKER_TEST_PAUSE_FILE,
// until the tight worker has failed the job once.
//
// Defect: the job went back to the queue and the tight worker's next
// LeaseJob, milliseconds later, took it again: three attempts on the one
// worker that could not bake it, and the job FAILED while the roomy worker
// was a moment from free.
// Every wait is for a job event (WatchJob).
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "tests/support/server_process.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::AssetsDir;
using testing::ServerProcess;

bool PausedAtRender(const v1::Job& j) { return j.state() == v1::JOB_STATE_RUNNING && j.stage() == "render"; }

TEST(RetryElsewhere, AJobAWorkerHasNoFreeMemoryForIsBakedByAnotherOnAttemptTwo) {
  ServerProcess server(/*local_workers=*/0);
  const fs::path pause = testing::NewTempDir("retry_elsewhere") / "pause";
  std::ofstream(pause) << "pause";
  auto roomy = testing::StartWorker(server.address(), {"--name=roomy"},
                                    {"IMPOSTOR_WORKER_TEST_PAUSE_FILE=" + pause.string()});
  const std::string busy = testing::SubmitSmallBake(
      server.bake(),
      testing::UploadGlb(server.assets(), AssetsDir() / "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb"),
      /*frames=*/3, /*resolution=*/64);
  ASSERT_TRUE(PausedAtRender(testing::WatchUntil(server.bake(), busy, PausedAtRender)));

  auto tight = testing::StartWorker(server.address(), {"--name=tight"},
                                    {"IMPOSTOR_WORKER_TEST_HOST_MEMORY=64000000000:100000000"});
  // 1024 px at supersampling 2: about 134 MB, more than the tight worker's
  // 100 MB free.
  const std::string id = testing::SubmitSmallBake(
      server.bake(), testing::UploadGlb(server.assets(), AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb"),
      /*frames=*/8, /*resolution=*/1024);
  const v1::Job requeued = testing::WatchUntil(server.bake(), id, testing::EndedOrRequeued);
  ASSERT_EQ(requeued.state(), v1::JOB_STATE_QUEUED) << requeued.DebugString();
  ASSERT_EQ(requeued.attempt_history_size(), 1) << requeued.DebugString();
  EXPECT_EQ(requeued.attempt_history(0).outcome(), v1::JobAttempt::OUTCOME_FAILED);
  EXPECT_EQ(requeued.attempt_history(0).worker_id().rfind("tight-", 0), 0u) << requeued.DebugString();

  fs::remove(pause);  // the roomy worker finishes its job and is free
  const v1::Job done = testing::WatchToEnd(server.bake(), id);
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.DebugString();
  EXPECT_EQ(done.attempts(), 2u) << done.DebugString();
  EXPECT_EQ(done.worker_id().rfind("roomy-", 0), 0u) << done.DebugString();
  int attempts_on_tight = 0;
  for (const v1::JobAttempt& a : done.attempt_history()) attempts_on_tight += a.worker_id().rfind("tight-", 0) == 0;
  EXPECT_EQ(attempts_on_tight, 1) << done.DebugString();
  EXPECT_EQ(testing::WatchToEnd(server.bake(), busy).state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_TRUE(tight->Running() && roomy->Running());
}

TEST(RetryElsewhere, AnOutOfRangeBoundIsAUsageError) {
  const fs::path data = testing::NewTempDir("retry_elsewhere_flags");
  for (const char* flag : {"--retry-elsewhere-seconds=-1", "--retry-elsewhere-seconds=3601"}) {
    testing::ChildProcess server({(testing::BinaryDir() / "impostor-server").string(), "--listen=127.0.0.1:0",
                                  "--data=" + data.string(), flag});
    EXPECT_EQ(server.Wait(), 2) << flag;
    EXPECT_NE(server.Stderr().find("--retry-elsewhere-seconds: "), std::string::npos) << server.Stderr();
  }
}

}  // namespace
}  // namespace impostor
