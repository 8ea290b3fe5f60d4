// RunTool (worker/output/run_tool.h), the way the worker runs the KTX2
// encoder: a cancelled job kills the tool at once instead of waiting for it
// (basisu can run for minutes), and the tool is reaped, not left running.
#include "worker/output/run_tool.h"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>

namespace impostor {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

fs::path LogPath(const std::string& tag) {
  return fs::temp_directory_path() / ("impostor_run_tool_" + tag + "_" + std::to_string(getpid()) + ".log");
}

// The pid a tool printed as its first line, once it has printed it (the
// tool writes it before it sleeps); 0 if it never does within 20 s.
pid_t WaitForPid(const fs::path& log) {
  const auto give_up = Clock::now() + std::chrono::seconds(20);
  while (Clock::now() < give_up) {
    std::ifstream in(log);
    std::string line;
    if (std::getline(in, line) && !line.empty() && in) return static_cast<pid_t>(std::stol(line));
    std::this_thread::yield();
  }
  return 0;
}

TEST(RunTool, ACancelledToolIsKilledAndReapedAtOnce) {
  const fs::path log = LogPath("cancel");
  std::atomic<bool> cancelled{false};
  pid_t tool = 0;
  std::thread canceller([&] {
    tool = WaitForPid(log);
    cancelled = true;
  });
  const auto start = Clock::now();
  auto ran = RunTool({"/bin/sh", "-c", "echo $$; exec sleep 60"}, log, &cancelled);
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  canceller.join();
  ASSERT_GT(tool, 0) << "the tool never started";
  EXPECT_EQ(ran.status().code(), absl::StatusCode::kCancelled) << ran.status();
  EXPECT_NE(ran.status().message().find("/bin/sh"), std::string::npos) << ran.status();
  // Without the cancel the call lasts the tool's 60 s.
  EXPECT_LT(seconds, 30.0);
  // Reaped: no such process any more (not even a zombie).
  EXPECT_EQ(::kill(tool, 0), -1);
  EXPECT_EQ(errno, ESRCH);
  fs::remove(log);
}

TEST(RunTool, AFlagAlreadySetStopsTheToolBeforeItFinishes) {
  const fs::path log = LogPath("early");
  const std::atomic<bool> cancelled{true};
  auto ran = RunTool({"/bin/sh", "-c", "sleep 60; echo finished"}, log, &cancelled);
  EXPECT_EQ(ran.status().code(), absl::StatusCode::kCancelled) << ran.status();
  fs::remove(log);
}

TEST(RunTool, WithoutCancellationATaskRunsToItsEnd) {
  const fs::path log = LogPath("plain");
  const std::atomic<bool> never{false};
  auto ran = RunTool({"/bin/sh", "-c", "echo one; echo two"}, log, &never);
  ASSERT_TRUE(ran.ok()) << ran.status();
  EXPECT_EQ(*ran, "one\ntwo\n");
  auto failed = RunTool({"/bin/sh", "-c", "echo why >&2; exit 4"}, log);
  EXPECT_EQ(failed.status().code(), absl::StatusCode::kInternal);
  EXPECT_NE(failed.status().message().find("exit status 4"), std::string::npos) << failed.status();
  EXPECT_NE(failed.status().message().find("why"), std::string::npos) << failed.status();
  EXPECT_EQ(RunTool({"/nonexistent/tool"}, log).status().code(), absl::StatusCode::kNotFound);
  fs::remove(log);
}

}  // namespace
}  // namespace impostor
