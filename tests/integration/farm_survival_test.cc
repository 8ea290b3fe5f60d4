// The farm never loses a job: real server and worker processes, killed with
// SIGKILL at known points of a bake (workers pause at their render stage
// while a test-controlled file exists), restarted, and checked on the jobs'
// final states and the bytes fetched.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
#include <thread>

#include <gtest/gtest.h>

#include "common/util/sha256.h"
#include "impostor/client.h"
#include "tests/support/server_process.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::AssetsDir;
using testing::ChildProcess;

// A worker that pauses at the render stage of every bake while `pause_file`
// exists.
std::unique_ptr<ChildProcess> StartWorker(const std::string& address, const fs::path& pause_file) {
  ::setenv("IMPOSTOR_WORKER_TEST_PAUSE_FILE", pause_file.c_str(), 1);
  auto worker = std::make_unique<ChildProcess>(std::vector<std::string>{
      (testing::BinaryDir() / "impostor-worker").string(), "--server=" + address, "--log-level=warn"});
  ::unsetenv("IMPOSTOR_WORKER_TEST_PAUSE_FILE");
  return worker;
}

void Touch(const fs::path& p) { std::ofstream(p) << "pause"; }

void Kill9(ChildProcess& process) {
  ::kill(process.pid(), SIGKILL);
  process.Terminate();  // reaps it
}

v1::SubmitBakeResponse Submit(v1::BakeService::Stub& bake, const v1::MeshInput& mesh, int frames, int resolution) {
  grpc::ClientContext ctx;
  v1::SubmitBakeRequest request;
  *request.mutable_mesh() = mesh;
  request.mutable_parameters()->set_frames(static_cast<uint32_t>(frames));
  request.mutable_parameters()->set_resolution(static_cast<uint32_t>(resolution));
  v1::SubmitBakeResponse response;
  const grpc::Status s = bake.SubmitBake(&ctx, request, &response);
  EXPECT_TRUE(s.ok()) << s.error_message();
  return response;
}

// Follows WatchJob until `done(job)` holds; returns that job.
v1::Job WatchUntil(v1::BakeService::Stub& bake, const std::string& job_id,
                   const std::function<bool(const v1::Job&)>& done) {
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::minutes(3));
  v1::WatchJobRequest request;
  request.set_job_id(job_id);
  auto reader = bake.WatchJob(&ctx, request);
  v1::Job job;
  while (reader->Read(&job)) {
    if (done(job)) {
      ctx.TryCancel();
      break;
    }
  }
  reader->Finish();
  return job;
}

bool PausedAtRender(const v1::Job& j) { return j.state() == v1::JOB_STATE_RUNNING && j.stage() == "render"; }

TEST(FarmSurvival, AJobWhoseWorkerIsKilledMidBakeIsBakedByAnother) {
  // Lease 5 s against the workers' 1 s heartbeat: a live worker never loses
  // its lease to a slow machine, only a dead one does.
  testing::ServerProcess server(/*local_workers=*/0, {"--lease-timeout-s=5"});
  const fs::path pause = testing::NewTempDir("pause_worker_death") / "pause";
  Touch(pause);
  auto doomed = testing::StartWorker(server.address(), {}, {"IMPOSTOR_WORKER_TEST_PAUSE_FILE=" + pause.string()});
  const v1::MeshInput mesh =
      testing::UploadGlb(server.assets(), AssetsDir() / "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb");
  const v1::SubmitBakeResponse job = Submit(server.bake(), mesh, 3, 64);
  ASSERT_TRUE(PausedAtRender(testing::WatchUntil(server.bake(), job.job_id(), PausedAtRender)));
  doomed->KillAndReap();
  fs::remove(pause);
  auto rescuer = testing::StartWorker(server.address());
  const v1::Job done = testing::WatchToEnd(server.bake(), job.job_id());
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
  EXPECT_GE(done.attempts(), 2u) << "a second lease, after the first worker's expired";
  EXPECT_GE(server.process().CountInLog("event=lease_expired"), 1) << server.process().Stderr();
  std::printf("farm survival: 1 job submitted, 1 worker killed mid-bake, %d completed (attempt %u)\n",
              done.state() == v1::JOB_STATE_SUCCEEDED ? 1 : 0, done.attempts());
}

// Watcher threads that only record what they saw: nothing asserts while
// they run (a failed ASSERT in a thread would terminate the test binary and
// leave processes behind). JoinAll waits for them with a deadline; on any
// other way out of the test the destructor first runs `stop` (which must make
// the threads' calls return, e.g. by killing the server so that they fail
// once their outage budget is spent), then joins them.
class WatcherThreads {
 public:
  explicit WatcherThreads(std::function<void()> stop) : stop_(std::move(stop)) {}
  ~WatcherThreads() {
    bool running = false;
    for (std::thread& t : threads_) running = running || t.joinable();
    if (running) stop_();
    for (std::thread& t : threads_) {
      if (t.joinable()) t.join();
    }
  }
  void Start(std::function<void()> body) {
    threads_.emplace_back([this, body = std::move(body)] {
      body();
      std::lock_guard lock(mu_);
      ++finished_;
      done_.notify_all();
    });
  }
  // True when every thread finished before `deadline`; joins them then.
  bool JoinAll(std::chrono::steady_clock::time_point deadline) {
    {
      std::unique_lock lock(mu_);
      if (!done_.wait_until(lock, deadline, [&] { return finished_ == threads_.size(); })) return false;
    }
    for (std::thread& t : threads_) t.join();
    return true;
  }

 private:
  std::function<void()> stop_;
  std::vector<std::thread> threads_;
  std::mutex mu_;
  std::condition_variable done_;
  size_t finished_ = 0;
};

// The head node goes down mid-bake (one job running, two queued, a watcher
// streaming each) and comes back on its address and data: no job is lost
// and every watcher ends with the job's result. `graceful`: SIGTERM, which
// lets the server close its streams ("watch again") and cancel what is in
// flight as it stops; otherwise SIGKILL.
void ServerStoppedMidBakeLosesNoJob(bool graceful) {
  const std::string tag = graceful ? "server_stop" : "server_death";
  const fs::path data = testing::NewTempDir(tag + "_data");
  const fs::path pause = testing::NewTempDir(tag + "_pause") / "pause";
  // Port 0, then the restart on the address it got: no port number is
  // guessed or reused from a socket closed earlier.
  auto server = std::make_unique<testing::ServerProcess>(0, data, "127.0.0.1:0");
  const std::string address = server->address();
  ASSERT_FALSE(address.empty()) << "impostor-server did not start";
  Touch(pause);
  auto worker = StartWorker(address, pause);

  // The budget bounds how long a watcher can outlive a failed restart.
  sdk::ClientOptions options;
  options.server = address;
  options.max_outage_seconds = 60;
  auto client = sdk::Client::Connect(options);
  ASSERT_TRUE(client.ok()) << client.status();
  const char* assets[] = {"props_pbr/Box/glTF-Binary/Box.glb", "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb",
                          "props_pbr/Duck/glTF-Binary/Duck.glb"};
  std::vector<sdk::SubmitResult> jobs;
  for (const char* asset : assets) {
    auto r = (*client)->SubmitBake(AssetsDir() / asset, {.frames = 3, .resolution = 64});
    ASSERT_TRUE(r.ok()) << asset << ": " << r.status();
    jobs.push_back(*r);
  }
  ASSERT_TRUE(PausedAtRender(WatchUntil(server->bake(), jobs[0].job_id, PausedAtRender)));

  // Watchers that are streaming when the server dies. Declared after the
  // client, so they are joined before it goes.
  std::vector<absl::StatusOr<sdk::JobUpdate>> finals(jobs.size(), absl::UnknownError("not watched"));
  WatcherThreads watchers([&] {
    fs::remove(pause);
    worker.reset();
    server.reset();
  });
  for (size_t i = 0; i < jobs.size(); ++i) {
    watchers.Start([&, i] { finals[i] = (*client)->WatchJob(jobs[i].job_id, [](const sdk::JobUpdate&) {}); });
  }
  if (graceful) {
    server->process().Terminate();
  } else {
    Kill9(server->process());
  }
  server = std::make_unique<testing::ServerProcess>(0, data, address);
  ASSERT_EQ(server->address(), address) << "the restarted server is not on the old address";
  ASSERT_TRUE(server->channel()->WaitForConnected(std::chrono::system_clock::now() + std::chrono::seconds(60)))
      << "the restarted server does not answer";
  fs::remove(pause);
  ASSERT_TRUE(watchers.JoinAll(std::chrono::steady_clock::now() + std::chrono::minutes(5)))
      << "a watcher did not return within 5 minutes";

  int completed = 0;
  for (size_t i = 0; i < jobs.size(); ++i) {
    ASSERT_TRUE(finals[i].ok()) << assets[i] << ": " << finals[i].status();
    EXPECT_EQ(finals[i]->state, sdk::JobState::kSucceeded) << assets[i] << ": " << finals[i]->error_message;
    const fs::path out = testing::NewTempDir(tag + "_fetch_" + std::to_string(i));
    auto fetched = (*client)->Fetch(jobs[i].cache_key, out);  // verifies every digest
    ASSERT_TRUE(fetched.ok()) << assets[i] << ": " << fetched.status();
    completed += finals[i]->state == sdk::JobState::kSucceeded;
  }
  EXPECT_EQ(::waitpid(worker->pid(), nullptr, WNOHANG), 0) << "the worker outlived the server's death";
  std::printf("farm survival: %zu jobs submitted, server %s mid-bake (1 running, %zu queued), %d completed\n",
              jobs.size(), graceful ? "stopped (SIGTERM)" : "killed", jobs.size() - 1, completed);
}

TEST(FarmSurvival, ServerKilledMidBakeLosesNoJobAndWatchersReconnect) { ServerStoppedMidBakeLosesNoJob(false); }

// A restart by the book (systemctl restart): the server cancels the calls
// still in flight as it stops, which a client must take for the outage it
// is, not for a final answer.
TEST(FarmSurvival, ServerStoppedMidBakeLosesNoJobAndWatchersReconnect) { ServerStoppedMidBakeLosesNoJob(true); }

TEST(FarmSurvival, CancelStopsTheRunningBakeAndFreesTheWorker) {
  testing::ServerProcess server(/*local_workers=*/0);
  const fs::path pause = testing::NewTempDir("pause_cancel") / "pause";
  Touch(pause);
  auto worker = testing::StartWorker(server.address(), {}, {"IMPOSTOR_WORKER_TEST_PAUSE_FILE=" + pause.string()});
  const v1::MeshInput helmet =
      testing::UploadGlb(server.assets(), AssetsDir() / "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb");
  const v1::SubmitBakeResponse big = Submit(server.bake(), helmet, 12, 2048);
  ASSERT_TRUE(PausedAtRender(testing::WatchUntil(server.bake(), big.job_id(), PausedAtRender)));

  const v1::MeshInput box = testing::UploadGlb(server.assets(), AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb");
  const v1::SubmitBakeResponse next = Submit(server.bake(), box, 3, 64);
  const auto cancel_time = std::chrono::steady_clock::now();
  {
    auto ctx = testing::ContextWithin();
    v1::CancelJobRequest cancel;
    cancel.set_job_id(big.job_id());
    v1::Job cancelled;
    ASSERT_TRUE(server.bake().CancelJob(ctx.get(), cancel, &cancelled).ok());
    EXPECT_EQ(cancelled.state(), v1::JOB_STATE_CANCELLED);
  }
  // The only worker hears of the cancel on a heartbeat, leaves the bake
  // (the pause file still exists: only the cancel can end the pause) and
  // takes the next job.
  const v1::Job leased = testing::WatchUntil(server.bake(), next.job_id(),
                                             [](const v1::Job& j) { return j.state() == v1::JOB_STATE_RUNNING; });
  const double freed_after = std::chrono::duration<double>(std::chrono::steady_clock::now() - cancel_time).count();
  EXPECT_EQ(leased.state(), v1::JOB_STATE_RUNNING);
  EXPECT_TRUE(worker->WaitForLog("event=job_cancel_requested job=" + big.job_id())) << worker->Stderr();
  fs::remove(pause);
  EXPECT_EQ(testing::WatchToEnd(server.bake(), next.job_id()).state(), v1::JOB_STATE_SUCCEEDED);

  auto ctx = testing::ContextWithin();
  v1::SubmitBakeRequest lookup;
  *lookup.mutable_mesh() = helmet;
  lookup.mutable_parameters()->set_frames(12);
  lookup.mutable_parameters()->set_resolution(2048);
  v1::LookupBakeResponse found;
  ASSERT_TRUE(server.bake().LookupBake(ctx.get(), lookup, &found).ok());
  EXPECT_FALSE(found.found()) << "the cancelled bake must not have run to the end";
  // Informational (speed belongs in bench/): how long the worker took to let go.
  std::printf("farm survival: cancelled bake released its worker after %.2f s\n", freed_after);
}

}  // namespace
}  // namespace impostor

namespace impostor {
namespace {

TEST(FarmLimits, AMeshOverTheWorkersTriangleLimitFailsNamingTheLimit) {
  testing::ServerProcess server(/*local_workers=*/0);
  auto worker = testing::StartWorker(server.address(), {"--max-triangles=1000"});
  const v1::MeshInput duck = testing::UploadGlb(server.assets(), AssetsDir() / "props_pbr/Duck/glTF-Binary/Duck.glb");
  const v1::SubmitBakeResponse job = Submit(server.bake(), duck, 3, 64);
  const v1::Job done = testing::WatchToEnd(server.bake(), job.job_id());
  EXPECT_EQ(done.state(), v1::JOB_STATE_FAILED);
  EXPECT_EQ(done.error().code(), static_cast<int>(grpc::StatusCode::RESOURCE_EXHAUSTED)) << done.error().message();
  // The load budget refuses the declared counts before reading: 12,636
  // indices are 4,212 triangles.
  EXPECT_NE(done.error().message().find("4212 triangles"), std::string::npos) << done.error().message();
  EXPECT_NE(done.error().message().find("max_triangles = 1000"), std::string::npos) << done.error().message();
  EXPECT_EQ(done.attempts(), 1u) << "a limit is not worth a retry";
}

TEST(FarmLimits, UploadsOverTheBlobLimitAreRefused) {
  testing::ServerProcess server(/*local_workers=*/0, {"--max-blob-bytes=1000"});
  const std::string bytes(2000, 'x');
  const grpc::Status s = testing::UploadBytes(server.assets(), bytes, testing::DigestOf(bytes));
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("2000"), std::string::npos) << s.error_message();
  EXPECT_NE(s.error_message().find("1000"), std::string::npos) << s.error_message();
}

}  // namespace
}  // namespace impostor
