// WorkerSupervisor with stand-in worker programs (shell scripts): it reports
// how each child ended, SIGTERMs children on Stop and SIGKILLs those still
// running at the deadline. Waits are on the exit reports, never on time.
#include "server/worker_supervisor.h"

#include "common/worker_exit_codes.h"

#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace impostor {
namespace {

namespace fs = std::filesystem;

// Collects on_exit reports from the supervisor's thread.
class ExitLog {
 public:
  WorkerSupervisor::ExitCallback Callback() {
    return [this](const std::string& worker_id, const std::string& how) {
      std::lock_guard lock(mu_);
      exits_.push_back({worker_id, how});
      cv_.notify_all();
    };
  }
  // The first `n` reports; a test failure if they do not come within a
  // minute (a hang guard, not a timing assertion).
  std::vector<std::pair<std::string, std::string>> WaitFor(size_t n) {
    std::unique_lock lock(mu_);
    EXPECT_TRUE(cv_.wait_for(lock, std::chrono::minutes(1), [&] { return exits_.size() >= n; }))
        << "only " << exits_.size() << " of " << n << " exits reported";
    return exits_;
  }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  std::vector<std::pair<std::string, std::string>> exits_;
};

class WorkerSupervisorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("supervisor_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // An executable shell script standing in for impostor-worker.
  fs::path Script(const std::string& name, const std::string& body) {
    const fs::path path = dir_ / name;
    std::ofstream(path) << "#!/bin/sh\n" << body << "\n";
    fs::permissions(path, fs::perms::owner_all);
    return path;
  }

  // A named pipe the scripts announce readiness on (their signal traps are
  // set), and a blocking wait for `n` announcements.
  fs::path ReadyPipe() {
    const fs::path pipe = dir_ / "ready";
    EXPECT_EQ(::mkfifo(pipe.c_str(), 0600), 0);
    return pipe;
  }
  static void WaitReady(const fs::path& pipe, int n) {
    int seen = 0;
    while (seen < n) {
      std::ifstream in(pipe);  // blocks until a script opens it to write
      std::string line;
      while (seen < n && std::getline(in, line)) seen += line == "ready";
    }
  }

  fs::path dir_;
};

bool StartsWith(const std::string& s, const std::string& prefix) { return s.rfind(prefix, 0) == 0; }

TEST_F(WorkerSupervisorTest, ReportsAWorkerKilledByASignalWithItsId) {
  ExitLog log;
  WorkerSupervisor supervisor(Script("crash.sh", "kill -SEGV $$"), "127.0.0.1:1", 1, {}, log.Callback());
  ASSERT_TRUE(supervisor.Start().ok());
  const auto exits = log.WaitFor(1);
  supervisor.Stop();
  ASSERT_GE(exits.size(), 1u);
  EXPECT_TRUE(StartsWith(exits[0].first, "local-0-")) << exits[0].first;
  EXPECT_EQ(exits[0].second, "killed by signal 11 (SIGSEGV)");
}

TEST_F(WorkerSupervisorTest, ReportsAnExitStatus) {
  ExitLog log;
  WorkerSupervisor supervisor(Script("exit3.sh", "exit 3"), "127.0.0.1:1", 1, {}, log.Callback());
  ASSERT_TRUE(supervisor.Start().ok());
  const auto exits = log.WaitFor(1);
  supervisor.Stop();
  ASSERT_GE(exits.size(), 1u);
  EXPECT_EQ(exits[0].second, "exited with status 3");
}

TEST_F(WorkerSupervisorTest, AWorkerWhoseTokenOrFlagsWereRefusedIsNotRestarted) {
  for (const int code : {kWorkerExitTokenRefused, kWorkerExitUsage}) {
    ExitLog log;
    WorkerSupervisor supervisor(Script("refused.sh", "exit " + std::to_string(code)), "127.0.0.1:1", 1, {},
                                log.Callback());
    ASSERT_TRUE(supervisor.Start().ok());
    const auto exits = log.WaitFor(1);
    supervisor.Stop();
    ASSERT_GE(exits.size(), 1u);
    EXPECT_EQ(exits[0].second, "exited with status " + std::to_string(code) + "; not restarted");
  }
}

TEST_F(WorkerSupervisorTest, StopTerminatesWorkersThatHonourSigterm) {
  ExitLog log;
  // Exits 0 on SIGTERM, as a drained worker does.
  const fs::path ready = ReadyPipe();
  WorkerSupervisor supervisor(
      Script("drains.sh", "trap 'exit 0' TERM\necho ready > " + ready.string() + "\nwhile :; do sleep 1; done"),
      "127.0.0.1:1", 2, {}, log.Callback());
  ASSERT_TRUE(supervisor.Start().ok());
  WaitReady(ready, 2);
  supervisor.Stop(std::chrono::steady_clock::now() + std::chrono::minutes(1));
  const auto exits = log.WaitFor(2);
  for (const auto& [worker, how] : exits) EXPECT_EQ(how, "exited with status 0") << worker;
}

TEST_F(WorkerSupervisorTest, StopKillsWorkersStillRunningAtTheDeadline) {
  ExitLog log;
  // Ignores SIGTERM, like a worker stuck in a long draw call.
  const fs::path ready = ReadyPipe();
  WorkerSupervisor supervisor(
      Script("stuck.sh", "trap '' TERM\necho ready > " + ready.string() + "\nexec sleep 1000"), "127.0.0.1:1", 1,
      {}, log.Callback());
  ASSERT_TRUE(supervisor.Start().ok());
  WaitReady(ready, 1);
  supervisor.Stop(std::chrono::steady_clock::now());
  const auto exits = log.WaitFor(1);
  ASSERT_GE(exits.size(), 1u);
  EXPECT_EQ(exits[0].second, "killed by signal 9 (SIGKILL)");
}

TEST_F(WorkerSupervisorTest, PassesItsArgumentsToTheWorker) {
  ExitLog log;
  const fs::path args = dir_ / "args.txt";
  WorkerSupervisor supervisor(Script("args.sh", "echo \"$@\" > " + args.string()), "farm:50051", 1,
                              {"--drain-seconds=5"}, log.Callback());
  ASSERT_TRUE(supervisor.Start().ok());
  log.WaitFor(1);
  supervisor.Stop();
  std::string line;
  std::getline(std::ifstream(args), line);
  EXPECT_EQ(line, "--server farm:50051 --name local-0 --drain-seconds=5");
}

TEST_F(WorkerSupervisorTest, AMissingWorkerBinaryIsRefusedNamingTheFlag) {
  WorkerSupervisor supervisor(dir_ / "no-such-worker", "127.0.0.1:1", 1);
  const absl::Status s = supervisor.Start();
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(s.message().find("--local-workers"), std::string::npos) << s;
}

}  // namespace
}  // namespace impostor
