// Where the SDK's log lines go (impostor/log.h, impostor_set_log_handler),
// through libimpostor.so itself as a game links it (public headers and
// exported symbols only), in a process that also uses spdlog and its default
// logger, as a game may. The line provoked is a real one: a cache directory
// holding an entry whose record cannot be read, which Cache::Open drops with
// a warning (no server needed: Open does not connect).
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <spdlog/sinks/ringbuffer_sink.h>
#include <spdlog/spdlog.h>

#include "impostor/cache.h"
#include "impostor/impostor_c.h"
#include "impostor/log.h"

namespace {

namespace fs = std::filesystem;
using impostor::sdk::Cache;
using impostor::sdk::LogLevel;
using impostor::sdk::SetLogHandler;

const std::string kKey(64, 'a');

struct Line {
  LogLevel level;
  std::string message;
};

class Lines {
 public:
  void Add(LogLevel level, std::string_view message) {
    std::lock_guard lock(mu_);
    lines_.push_back({level, std::string(message)});
  }
  std::vector<Line> Get() {
    std::lock_guard lock(mu_);
    return lines_;
  }

 private:
  std::mutex mu_;
  std::vector<Line> lines_;
};

class SdkLogTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // The game's own logger, listening to everything: the SDK must not use it.
    game_sink_ = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(64);
    previous_ = spdlog::default_logger();
    auto game = std::make_shared<spdlog::logger>("game", game_sink_);
    game->set_level(spdlog::level::trace);
    spdlog::set_default_logger(game);
  }
  void TearDown() override {
    SetLogHandler(nullptr);  // the default, for the next test
    spdlog::set_default_logger(previous_);
  }

  // A cache directory whose one entry has an unreadable record.
  fs::path DamagedCacheDir(const std::string& name) {
    const fs::path dir = fs::temp_directory_path() / ("impostor_sdk_log_" + name + "_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    {
      auto cache = Cache::Open(Options(dir));  // lays the directory out
      EXPECT_TRUE(cache.ok()) << cache.status();
    }
    fs::create_directories(dir / "entries" / kKey);
    std::ofstream(dir / "entries" / kKey / ".entry") << "{ not json";
    return dir;
  }

  static impostor::sdk::CacheOptions Options(const fs::path& dir) {
    impostor::sdk::CacheOptions o;
    o.server = "127.0.0.1:1";
    o.dir = dir;
    return o;
  }

  // Opens the cache at `dir` (dropping the damaged entry) with stdout and
  // stderr captured; returns what they got.
  std::string OpenCapturingOutput(const fs::path& dir) {
    ::testing::internal::CaptureStdout();
    ::testing::internal::CaptureStderr();
    {
      auto cache = Cache::Open(Options(dir));
      EXPECT_TRUE(cache.ok()) << cache.status();
    }
    std::string out = ::testing::internal::GetCapturedStderr();
    out += ::testing::internal::GetCapturedStdout();
    EXPECT_FALSE(fs::exists(dir / "entries" / kKey)) << "the damaged entry was not dropped: no line to look for";
    return out;
  }

  void ExpectGameLoggerSawNothing() {
    for (const std::string& line : game_sink_->last_formatted()) ADD_FAILURE() << "the game's logger got: " << line;
  }

  std::shared_ptr<spdlog::sinks::ringbuffer_sink_mt> game_sink_;
  std::shared_ptr<spdlog::logger> previous_;
};

using CacheLog = SdkLogTest;
using CApiLog = SdkLogTest;

TEST_F(CacheLog, HandlerGetsTheWarningAndNothingElseDoes) {
  const fs::path dir = DamagedCacheDir("handler");
  Lines lines;
  SetLogHandler([&lines](LogLevel level, std::string_view message) { lines.Add(level, message); },
                LogLevel::kWarning);
  const std::string output = OpenCapturingOutput(dir);
  const std::vector<Line> got = lines.Get();
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].level, LogLevel::kWarning);
  EXPECT_EQ(got[0].message.rfind("cache: dropping unreadable entry ", 0), 0u) << got[0].message;
  EXPECT_NE(got[0].message.find(kKey), std::string::npos) << got[0].message;
  EXPECT_EQ(got[0].message.find('\n'), std::string::npos) << "a line without its newline";
  EXPECT_EQ(output, "") << "stderr and stdout stay quiet";
  ExpectGameLoggerSawNothing();
  fs::remove_all(dir);
}

TEST_F(CacheLog, MinLevelOffGetsNothing) {
  const fs::path dir = DamagedCacheDir("off");
  Lines lines;
  SetLogHandler([&lines](LogLevel level, std::string_view message) { lines.Add(level, message); }, LogLevel::kOff);
  EXPECT_EQ(OpenCapturingOutput(dir), "");
  EXPECT_TRUE(lines.Get().empty());

  // Above the warning's level: nothing either.
  const fs::path dir2 = DamagedCacheDir("error");
  SetLogHandler([&lines](LogLevel level, std::string_view message) { lines.Add(level, message); }, LogLevel::kError);
  EXPECT_EQ(OpenCapturingOutput(dir2), "");
  EXPECT_TRUE(lines.Get().empty());

  // No handler and off: silence without a handler.
  const fs::path dir3 = DamagedCacheDir("null_off");
  SetLogHandler(nullptr, LogLevel::kOff);
  EXPECT_EQ(OpenCapturingOutput(dir3), "");
  ExpectGameLoggerSawNothing();
  for (const fs::path& d : {dir, dir2, dir3}) fs::remove_all(d);
}

TEST_F(CacheLog, DefaultIsOneLineOnStderrNotTheProcessDefaultLogger) {
  const fs::path dir = DamagedCacheDir("default");
  {
    Lines lines;
    SetLogHandler([&lines](LogLevel level, std::string_view message) { lines.Add(level, message); });
  }
  SetLogHandler(nullptr);  // restores the default of a program that never called it
  ::testing::internal::CaptureStdout();
  ::testing::internal::CaptureStderr();
  {
    auto cache = Cache::Open(Options(dir));
    ASSERT_TRUE(cache.ok()) << cache.status();
  }
  const std::string err = ::testing::internal::GetCapturedStderr();
  const std::string out = ::testing::internal::GetCapturedStdout();
  EXPECT_NE(err.find("[impostor-sdk] [warning] cache: dropping unreadable entry "), std::string::npos) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_EQ(out, "") << "diagnostics never go to stdout";
  ExpectGameLoggerSawNothing();
  fs::remove_all(dir);
}

TEST_F(CacheLog, HandlerMayReplaceItselfAndIsNotCalledAfterward) {
  const fs::path dir = DamagedCacheDir("reentrant");
  const fs::path dir2 = DamagedCacheDir("reentrant2");
  std::atomic<int> calls{0};
  SetLogHandler([&calls](LogLevel, std::string_view) {
    ++calls;
    SetLogHandler(nullptr, LogLevel::kOff);  // from inside: no deadlock
  });
  EXPECT_EQ(OpenCapturingOutput(dir), "");
  EXPECT_EQ(OpenCapturingOutput(dir2), "");
  EXPECT_EQ(calls.load(), 1);
  for (const fs::path& d : {dir, dir2}) fs::remove_all(d);
}

TEST_F(CacheLog, SetLogHandlerWaitsForACallUnderWayOnAnotherThread) {
  const fs::path dir = DamagedCacheDir("wait");
  std::atomic<bool> in_handler{false};
  std::atomic<bool> handler_done{false};
  SetLogHandler([&](LogLevel, std::string_view) {
    in_handler = true;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    handler_done = true;
  });
  std::thread opener([&] { (void)Cache::Open(Options(dir)); });
  while (!in_handler) std::this_thread::yield();
  SetLogHandler(nullptr, LogLevel::kOff);
  EXPECT_TRUE(handler_done) << "SetLogHandler returned while the handler it replaced was running";
  opener.join();
  fs::remove_all(dir);
}

struct CLines {
  std::mutex mu;
  std::vector<std::pair<int, std::string>> lines;
};

void CollectLine(int level, const char* message, void* user) {
  auto* c = static_cast<CLines*>(user);
  std::lock_guard lock(c->mu);
  c->lines.emplace_back(level, message);
}

impostor_status OpenAndCloseWithC(const fs::path& dir) {
  impostor_cache_options o;
  impostor_cache_options_init(&o);
  const std::string d = dir.string();
  o.server = "127.0.0.1:1";
  o.dir = d.c_str();
  impostor_cache* cache = nullptr;
  const impostor_status s = impostor_cache_open(&o, &cache);
  impostor_cache_close(cache);
  return s;
}

TEST_F(CApiLog, HandlerGetsWarningsWithItsUserPointer) {
  const fs::path dir = DamagedCacheDir("c");
  CLines collected;
  ASSERT_EQ(impostor_set_log_handler(&CollectLine, IMPOSTOR_LOG_WARNING, &collected), IMPOSTOR_OK);
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(OpenAndCloseWithC(dir), IMPOSTOR_OK) << impostor_last_error();
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
  ASSERT_EQ(collected.lines.size(), 1u);
  EXPECT_EQ(collected.lines[0].first, IMPOSTOR_LOG_WARNING);
  EXPECT_EQ(collected.lines[0].second.rfind("cache: dropping unreadable entry ", 0), 0u) << collected.lines[0].second;
  ExpectGameLoggerSawNothing();

  // min_level IMPOSTOR_LOG_OFF: the handler gets nothing.
  const fs::path dir2 = DamagedCacheDir("c_off");
  ASSERT_EQ(impostor_set_log_handler(&CollectLine, IMPOSTOR_LOG_OFF, &collected), IMPOSTOR_OK);
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(OpenAndCloseWithC(dir2), IMPOSTOR_OK) << impostor_last_error();
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
  EXPECT_EQ(collected.lines.size(), 1u);

  // A level that is none: refused, nothing changed.
  EXPECT_EQ(impostor_set_log_handler(nullptr, 5, nullptr), IMPOSTOR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(impostor_last_error()).find("min_level"), std::string::npos) << impostor_last_error();
  EXPECT_EQ(impostor_set_log_handler(nullptr, -1, nullptr), IMPOSTOR_INVALID_ARGUMENT);
  const fs::path dir3 = DamagedCacheDir("c_unchanged");
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(OpenAndCloseWithC(dir3), IMPOSTOR_OK);
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "") << "still the handler at IMPOSTOR_LOG_OFF";

  // NULL: stderr again.
  const fs::path dir4 = DamagedCacheDir("c_null");
  ASSERT_EQ(impostor_set_log_handler(nullptr, IMPOSTOR_LOG_WARNING, nullptr), IMPOSTOR_OK);
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(OpenAndCloseWithC(dir4), IMPOSTOR_OK);
  const std::string err = ::testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("[warning] cache: dropping unreadable entry "), std::string::npos) << err;
  EXPECT_EQ(collected.lines.size(), 1u);
  for (const fs::path& d : {dir, dir2, dir3, dir4}) fs::remove_all(d);
}

}  // namespace
