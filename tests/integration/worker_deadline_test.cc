// A server that takes calls but cannot answer them in time (its database
// away; here the process stopped with SIGSTOP) while a worker completes a
// job. CompleteJob's 30 s deadline used to end the worker's try for good:
// `job_done ok=false error="Deadline Exceeded"` after one deadline, well
// within --max-outage-seconds, though the server recorded the queued call
// later. Now a deadline counts as an outage: the worker tries again until
// the server answers, and its log says how the result went.
#include <signal.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "tests/support/server_process.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::ServerProcess;

TEST(WorkerDeadline, ACompleteJobThatTimesOutIsRetriedWithinTheOutageBudget) {
  const fs::path dir = testing::NewTempDir("worker_deadline");
  const fs::path pause = dir / "pause";
  std::ofstream(pause) << "complete";
  // Leases outlast the stop, so the result is the one recorded.
  ServerProcess server(/*local_workers=*/0, {"--lease-timeout-s=600"});
  // Keepalive off the race: at its default (20 s + 10 s for the answer) it
  // gives the connection up as UNAVAILABLE about when the 30 s deadline
  // fires, and which came first decided whether this test saw a deadline.
  auto worker = testing::StartWorker(server.address(), {"--name=patient", "--keepalive-seconds=600"},
                                     {"IMPOSTOR_WORKER_TEST_PAUSE_FILE=" + pause.string()});
  v1::SubmitBakeRequest request;
  *request.mutable_mesh() =
      testing::UploadGlb(server.assets(), testing::AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb");
  request.mutable_parameters()->set_frames(3);
  request.mutable_parameters()->set_resolution(64);
  v1::SubmitBakeResponse submitted;
  {
    auto ctx = testing::ContextWithin();
    ASSERT_TRUE(server.bake().SubmitBake(ctx.get(), request, &submitted).ok());
  }
  const v1::Job uploaded = testing::WatchUntil(server.bake(), submitted.job_id(), [](const v1::Job& j) {
    return testing::IsTerminalState(j.state()) || j.stage() == "uploaded";
  });
  ASSERT_EQ(uploaded.stage(), "uploaded") << uploaded.DebugString();

  server.process().Signal(SIGSTOP);
  fs::remove(pause);
  // Both the retry line and the old final line name the deadline.
  const bool timed_out = worker->WaitForLog("Deadline Exceeded", 1, std::chrono::seconds(50));
  server.process().Signal(SIGCONT);
  ASSERT_TRUE(timed_out) << "CompleteJob never timed out";

  const v1::Job done = testing::WatchToEnd(server.bake(), submitted.job_id());
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.DebugString();
  EXPECT_EQ(done.attempts(), 1u);
  ASSERT_TRUE(worker->WaitForLog("event=job_done"));
  EXPECT_EQ(worker->CountInLog("event=rpc_retry rpc=CompleteJob code=4"), 1) << worker->Stderr();
  EXPECT_EQ(worker->CountInLog("ok=false"), 0) << "the worker said its result was lost";
}

}  // namespace
}  // namespace impostor
