// A request too large for a worker's memory, through a real impostor-server
// and real impostor-worker processes whose host memory is made small with
// IMPOSTOR_WORKER_TEST_HOST_MEMORY (worker/test_faults.h):
//  * over the total of every worker: the server never leases it (the
//    worker reports its memory with each LeaseJob, issue 44); the job waits
//    with the reason as its stage and fails with it (UNPLACEABLE) after
//    --unplaceable-timeout-seconds, without an attempt and without
//    rendering (the worker would crash at its render stage:
//    IMPOSTOR_WORKER_TEST_CRASH_ON), and the worker bakes the next job (it
//    used to die in std::bad_alloc, three attempts, each one a worker down);
//  * within the total but over what is available now: UNAVAILABLE, and the
//    job is baked by another worker.
// Every wait is for a job event (WatchJob).
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/server_process.h"

namespace impostor {
namespace {

using testing::ServerProcess;

constexpr char kBox[] = "props_pbr/Box/glTF-Binary/Box.glb";
constexpr char kBoxTextured[] = "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb";

// A worker whose leases of one job ended badly is paused for an hour: a
// retryable failure shows at once, as a worker that takes no more jobs.
const std::vector<std::string> kPauseAfterOneFailure = {"--worker-failure-limit=1", "--worker-pause-seconds=3600"};

std::string Submit(ServerProcess& server, const char* mesh, uint32_t resolution) {
  // supersampling: the default, 2
  return testing::SubmitSmallBake(server.bake(), testing::UploadGlb(server.assets(), testing::AssetsDir() / mesh),
                                  /*frames=*/8, resolution);
}

TEST(MemoryLimit, ARequestOverEveryWorkersMemoryWaitsThenFailsWithTheReasonNeverAnAttempt) {
  std::vector<std::string> flags = kPauseAfterOneFailure;
  flags.push_back("--unplaceable-timeout-seconds=2");
  ServerProcess server(/*local_workers=*/0, flags);
  auto worker = testing::StartWorker(server.address(), {"--name=small"},
                                     {"IMPOSTOR_WORKER_TEST_HOST_MEMORY=100000000",
                                      std::string("IMPOSTOR_WORKER_TEST_CRASH_ON=") + "Box.glb"});
  // 1024 px at supersampling 2: about 134 MB on lavapipe, more than the
  // worker's 100 MB.
  const std::string id = Submit(server, kBox, 1024);
  const v1::Job waiting = testing::WatchUntil(server.bake(), id, [](const v1::Job& j) {
    return j.stage().rfind("waiting for a worker", 0) == 0 || j.state() != v1::JOB_STATE_QUEUED;
  });
  EXPECT_EQ(waiting.state(), v1::JOB_STATE_QUEUED) << waiting.DebugString();
  const v1::Job failed = testing::WatchToEnd(server.bake(), id);
  ASSERT_EQ(failed.state(), v1::JOB_STATE_FAILED) << failed.DebugString();
  EXPECT_EQ(failed.error().code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << failed.error().message();
  EXPECT_EQ(failed.error().reason(), "UNPLACEABLE");
  EXPECT_EQ(failed.attempts(), 0u);
  const std::string& message = failed.error().message();
  EXPECT_EQ(message.rfind("no worker could bake it for 2 s (--unplaceable-timeout-seconds): waiting for a worker "
                          "with at least ",
                          0),
            0u)
      << message;
  EXPECT_NE(message.find(" of host memory (the most any worker has: 100 MB) for an atlas of 1024 px at "
                         "supersampling 2 (frames 8)"),
            std::string::npos)
      << message;
  // Not held against the worker: it bakes the next job, one that fits.
  const v1::Job next = testing::WatchToEnd(server.bake(), Submit(server, kBoxTextured, 64));
  EXPECT_EQ(next.state(), v1::JOB_STATE_SUCCEEDED) << next.error().message();
  EXPECT_EQ(next.worker_id().rfind("small-", 0), 0u) << next.worker_id();
  EXPECT_TRUE(worker->Running()) << "the worker died";
}

TEST(MemoryLimit, AWorkerShortOfFreeMemorySendsTheJobToAnother) {
  ServerProcess server(/*local_workers=*/0, kPauseAfterOneFailure);
  auto tight = testing::StartWorker(server.address(), {"--name=tight"},
                                    {"IMPOSTOR_WORKER_TEST_HOST_MEMORY=64000000000:100000000"});
  const std::string id = Submit(server, kBox, 1024);
  const v1::Job requeued = testing::WatchUntil(server.bake(), id, testing::EndedOrRequeued);
  ASSERT_EQ(requeued.state(), v1::JOB_STATE_QUEUED) << requeued.DebugString();
  ASSERT_GE(requeued.attempt_history_size(), 1);
  const v1::JobAttempt& first = requeued.attempt_history(0);
  EXPECT_EQ(first.outcome(), v1::JobAttempt::OUTCOME_FAILED);
  EXPECT_NE(first.message().find("this worker has 64.0 GB (IMPOSTOR_WORKER_TEST_HOST_MEMORY) but 100 MB available "
                                 "now (IMPOSTOR_WORKER_TEST_HOST_MEMORY): another worker may take it"),
            std::string::npos)
      << first.message();

  // The tight worker is paused; a worker with room bakes the job.
  auto roomy = testing::StartWorker(server.address(), {"--name=roomy"});
  const v1::Job done = testing::WatchToEnd(server.bake(), id);
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
  EXPECT_EQ(done.worker_id().rfind("roomy-", 0), 0u) << done.worker_id();
  EXPECT_EQ(done.attempts(), 2u);
}

}  // namespace
}  // namespace impostor
