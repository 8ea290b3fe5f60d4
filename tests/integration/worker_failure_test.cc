// The README's "workers may die" promises with real processes: a hung
// worker (SIGSTOP) loses its lease and its late result is refused; a job
// fails for good after --max-attempts lease expiries, naming the last
// error; --local-workers restarts a worker that died. Workers pause at their
// render stage while a test-controlled file exists (heartbeats continue), so
// every step waits for an event, never for time.
#include <signal.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;

// Leases are 5x the workers' 1 s heartbeat: a live worker on a loaded
// machine keeps its lease, a hung or dead one loses it.
const std::vector<std::string> kShortLeases = {"--lease-timeout-s=5"};

std::string PauseEnv(const fs::path& pause) { return "IMPOSTOR_WORKER_TEST_PAUSE_FILE=" + pause.string(); }

bool PausedAtRender(const v1::Job& j) { return j.state() == v1::JOB_STATE_RUNNING && j.stage() == "render"; }

std::string SubmitSmall(ServerProcess& server, const std::string& asset) {
  const v1::MeshInput mesh = UploadGlb(server.assets(), AssetsDir() / asset);
  v1::SubmitBakeRequest request;
  *request.mutable_mesh() = mesh;
  request.mutable_parameters()->set_frames(3);
  request.mutable_parameters()->set_resolution(64);
  v1::SubmitBakeResponse response;
  auto ctx = ContextWithin();
  const grpc::Status s = server.bake().SubmitBake(ctx.get(), request, &response);
  EXPECT_TRUE(s.ok()) << asset << ": " << s.error_message();
  return response.job_id();
}

v1::Job GetJob(ServerProcess& server, const std::string& job_id) {
  auto ctx = ContextWithin();
  v1::GetJobRequest request;
  request.set_job_id(job_id);
  v1::Job job;
  const grpc::Status s = server.bake().GetJob(ctx.get(), request, &job);
  EXPECT_TRUE(s.ok()) << job_id << ": " << s.error_message();
  return job;
}

TEST(WorkerFailure, AHungWorkerLosesItsLeaseAnotherBakesTheJobAndTheLateResultIsRefused) {
  ServerProcess server(/*local_workers=*/0, kShortLeases);
  const fs::path pause = NewTempDir("hung_worker") / "pause";
  std::ofstream(pause) << "pause";
  auto hung = StartWorker(server.address(), {"--name=hung"}, {PauseEnv(pause)});
  const std::string job_id = SubmitSmall(server, "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb");
  ASSERT_TRUE(PausedAtRender(WatchUntil(server.bake(), job_id, PausedAtRender)));

  // Hung, not dead: the process and its connection stay, its heartbeats stop.
  hung->Signal(SIGSTOP);
  ASSERT_TRUE(server.process().WaitForLog("event=lease_expired job=" + job_id + " worker=\"hung"))
      << server.process().Stderr();
  // The pause file stays: the hung worker, once resumed, is still paused at
  // its render stage, so only the refused heartbeat can end its bake.
  auto rescuer = StartWorker(server.address(), {"--name=rescuer"});
  const v1::Job done = WatchToEnd(server.bake(), job_id);
  ASSERT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
  EXPECT_GE(done.attempts(), 2u);

  // The hung worker wakes up: its next heartbeat is refused, it drops the
  // job, and the rescuer's result stands.
  hung->Signal(SIGCONT);
  EXPECT_TRUE(hung->WaitForLog("event=lease_lost job=" + job_id)) << hung->Stderr();
  EXPECT_TRUE(hung->WaitForLog("event=job_dropped job=" + job_id)) << hung->Stderr();
  const v1::Job after = GetJob(server, job_id);
  EXPECT_EQ(after.state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(after.result().manifest_json().hash(), done.result().manifest_json().hash());
  EXPECT_TRUE(hung->Running()) << "a lost lease is not a reason to exit";
}

TEST(WorkerFailure, AJobFailsAfterMaxAttemptsLeaseExpiriesNamingTheLastError) {
  std::vector<std::string> args = kShortLeases;
  args.push_back("--max-attempts=2");
  ServerProcess server(/*local_workers=*/0, args);
  const fs::path pause = NewTempDir("max_attempts") / "pause";
  std::ofstream(pause) << "pause";
  const std::string job_id = SubmitSmall(server, "props_pbr/Box/glTF-Binary/Box.glb");
  for (int attempt = 1; attempt <= 2; ++attempt) {
    SCOPED_TRACE("attempt " + std::to_string(attempt));
    const std::string name = "doomed-" + std::to_string(attempt);
    auto worker = StartWorker(server.address(), {"--name=" + name}, {PauseEnv(pause)});
    const v1::Job paused = WatchUntil(server.bake(), job_id, [&](const v1::Job& j) {
      return PausedAtRender(j) && j.attempts() == static_cast<uint32_t>(attempt);
    });
    ASSERT_TRUE(PausedAtRender(paused));
    worker->KillAndReap();
    ASSERT_TRUE(server.process().WaitForLog("event=lease_expired job=" + job_id + " worker=\"" + name))
        << server.process().Stderr();
  }
  const v1::Job done = WatchToEnd(server.bake(), job_id);
  EXPECT_EQ(done.state(), v1::JOB_STATE_FAILED);
  EXPECT_EQ(done.attempts(), 2u);
  // Every lease ended with a dead worker: a poison job, reported as such.
  EXPECT_EQ(done.error().code(), static_cast<int>(grpc::StatusCode::INTERNAL)) << done.error().message();
  EXPECT_NE(done.error().message().find("lease expired 2 times"), std::string::npos) << done.error().message();
  EXPECT_NE(done.error().message().find("doomed-2"), std::string::npos)
      << "names the last worker: " << done.error().message();

  // A third worker finds nothing to do: the job is not retried again.
  auto ctx = ContextWithin();
  v1::LeaseJobRequest lease;
  lease.set_worker_id("probe");
  v1::LeaseJobResponse response;
  ASSERT_TRUE(server.workers().LeaseJob(ctx.get(), lease, &response).ok());
  EXPECT_FALSE(response.has_job());
}

TEST(WorkerFailure, LocalWorkersAreRestartedWhenTheyDie) {
  ServerProcess server(/*local_workers=*/1);
  ChildProcess& log = server.process();
  ASSERT_TRUE(log.WaitForLog("event=worker_started index=0")) << log.Stderr();
  const std::string stderr_text = log.Stderr();
  const size_t at = stderr_text.find("event=worker_started index=0 pid=");
  ASSERT_NE(at, std::string::npos);
  const pid_t first = static_cast<pid_t>(std::stol(stderr_text.substr(at + std::strlen("event=worker_started index=0 pid="))));
  ASSERT_GT(first, 0);
  ASSERT_EQ(::kill(first, SIGKILL), 0) << "local worker pid " << first;

  ASSERT_TRUE(log.WaitForLog("event=worker_exited index=0 pid=" + std::to_string(first))) << log.Stderr();
  ASSERT_TRUE(log.WaitForLog("event=worker_started index=0", 2)) << log.Stderr();
  EXPECT_EQ(log.CountInLog("how=\"killed by signal 9 (SIGKILL)\""), 1) << log.Stderr();

  // The new worker serves.
  const std::string job_id = SubmitSmall(server, "props_pbr/Box/glTF-Binary/Box.glb");
  const v1::Job done = WatchToEnd(server.bake(), job_id);
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
  EXPECT_EQ(done.attempts(), 1u);
}

// Cancel lands between render chunks, not only before rendering starts: the
// worker pauses after its first chunk (16 frames of 64) until the cancel
// arrives on a heartbeat, and the renderer stops before the next chunk.
TEST(CancelMidRender, TheRendererStopsBetweenChunksAndTheWorkerTakesTheNextJob) {
  ServerProcess server(/*local_workers=*/0);
  const fs::path pause = NewTempDir("cancel_mid_render") / "pause";
  std::ofstream(pause) << "render-chunk";
  auto worker = StartWorker(server.address(), {"--name=chunky"}, {PauseEnv(pause)});
  const v1::MeshInput box = UploadGlb(server.assets(), AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb");
  v1::SubmitBakeRequest request;
  *request.mutable_mesh() = box;
  request.mutable_parameters()->set_frames(8);  // 64 frames: 4 chunks of 16
  request.mutable_parameters()->set_resolution(256);
  v1::SubmitBakeResponse big;
  {
    auto ctx = ContextWithin();
    ASSERT_TRUE(server.bake().SubmitBake(ctx.get(), request, &big).ok());
  }
  // Rendering has begun when the render stage's progress moves past where
  // the stage started.
  float render_start = -1;
  const v1::Job mid = WatchUntil(server.bake(), big.job_id(), [&](const v1::Job& j) {
    if (j.state() != v1::JOB_STATE_RUNNING || j.stage() != "render") return false;
    if (render_start < 0) render_start = j.progress();
    return j.progress() > render_start;
  });
  ASSERT_EQ(mid.stage(), "render");
  {
    auto ctx = ContextWithin();
    v1::CancelJobRequest cancel;
    cancel.set_job_id(big.job_id());
    v1::Job cancelled;
    ASSERT_TRUE(server.bake().CancelJob(ctx.get(), cancel, &cancelled).ok());
    EXPECT_EQ(cancelled.state(), v1::JOB_STATE_CANCELLED);
  }
  ASSERT_TRUE(worker->WaitForLog("event=job_failed job=" + big.job_id())) << worker->Stderr();
  EXPECT_EQ(worker->CountInLog("render cancelled after 16 of 64 frames"), 1) << worker->Stderr();

  fs::remove(pause);
  const std::string next = SubmitSmall(server, "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb");
  const v1::Job done = WatchToEnd(server.bake(), next);
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
  EXPECT_TRUE(worker->Running());
  EXPECT_EQ(GetJob(server, big.job_id()).state(), v1::JOB_STATE_CANCELLED);
}

}  // namespace
}  // namespace impostor::testing
