#include "client/base/sdk_log.h"

#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>

#include <spdlog/sinks/sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>

#include "impostor/log.h"

namespace impostor {
namespace {

using sdk::LogHandler;
using sdk::LogLevel;

sdk::LogLevel FromSpdlog(spdlog::level::level_enum level) {
  switch (level) {
    case spdlog::level::trace:
    case spdlog::level::debug: return LogLevel::kDebug;
    case spdlog::level::info: return LogLevel::kInfo;
    case spdlog::level::warn: return LogLevel::kWarning;
    default: return LogLevel::kError;  // err, critical
  }
}

spdlog::level::level_enum ToSpdlog(LogLevel level) {
  switch (level) {
    case LogLevel::kDebug: return spdlog::level::trace;  // everything
    case LogLevel::kInfo: return spdlog::level::info;
    case LogLevel::kWarning: return spdlog::level::warn;
    case LogLevel::kError: return spdlog::level::err;
    case LogLevel::kOff: break;
  }
  return spdlog::level::off;
}

// The logger's one sink: the handler, or stderr when there is none.
//
// One recursive mutex serialises the handler's calls and guards the
// handler: SetLogHandler waits for a call under way on another thread (so
// the handler it replaces is never called after it returns, and a C
// caller may free its `user` data then), while a handler that calls
// SetLogHandler, or logs through the SDK, on its own thread does not
// deadlock.
class HandlerSink final : public spdlog::sinks::sink {
 public:
  HandlerSink() : stderr_(std::make_shared<spdlog::sinks::stderr_color_sink_mt>()) {}

  void log(const spdlog::details::log_msg& msg) override {
    std::lock_guard lock(mu_);
    if (msg.level < min_level_) return;  // a line that raced a SetLogHandler
    if (handler_ == nullptr) {
      stderr_->log(msg);
      return;
    }
    // A copy: a handler that replaces itself lives on until it returns.
    const std::shared_ptr<const LogHandler> handler = handler_;
    try {
      (*handler)(FromSpdlog(msg.level), std::string_view(msg.payload.data(), msg.payload.size()));
    } catch (...) {
      // impostor/log.h: the line is lost, the SDK goes on.
    }
  }
  void flush() override { stderr_->flush(); }
  void set_pattern(const std::string& pattern) override { stderr_->set_pattern(pattern); }
  void set_formatter(std::unique_ptr<spdlog::formatter> formatter) override {
    stderr_->set_formatter(std::move(formatter));
  }

  // Returns the handler replaced, for the caller to destroy outside the
  // lock (its captures' destructors may do anything).
  std::shared_ptr<const LogHandler> Set(LogHandler handler, spdlog::level::level_enum min_level,
                                        spdlog::logger& logger) {
    std::shared_ptr<const LogHandler> next;
    if (handler != nullptr) next = std::make_shared<const LogHandler>(std::move(handler));
    std::lock_guard lock(mu_);
    std::swap(handler_, next);
    min_level_ = min_level;
    logger.set_level(min_level);  // drops lower lines before they are formatted
    return next;
  }

 private:
  const std::shared_ptr<spdlog::sinks::sink> stderr_;
  std::recursive_mutex mu_;
  std::shared_ptr<const LogHandler> handler_;  // null: stderr
  spdlog::level::level_enum min_level_ = spdlog::level::warn;
};

struct SdkLogger {
  std::shared_ptr<HandlerSink> sink = std::make_shared<HandlerSink>();
  spdlog::logger logger{"impostor-sdk", sink};

  SdkLogger() {
    // Before there was a handler the SDK's lines went to spdlog's default
    // logger, which prints info and above (on stdout) in a program that
    // leaves it alone. The SDK has no info lines, so warnings and above
    // show the same lines, now on stderr with the diagnostics. An error
    // inside a sink is dropped rather than reported on stderr.
    logger.set_level(spdlog::level::warn);
    logger.set_error_handler([](const std::string&) {});
  }
};

SdkLogger& Instance() {
  static SdkLogger* const instance = new SdkLogger();  // never destroyed: see sdk_log.h
  return *instance;
}

}  // namespace

spdlog::logger& SdkLog() { return Instance().logger; }

namespace sdk {

void SetLogHandler(LogHandler handler, LogLevel min_level) {
  SdkLogger& sdk = Instance();
  std::shared_ptr<const LogHandler> replaced = sdk.sink->Set(std::move(handler), ToSpdlog(min_level), sdk.logger);
  // `replaced` is destroyed here, outside the sink's lock.
}

}  // namespace sdk
}  // namespace impostor
