#include "common/net/failover_channel.h"

#include <algorithm>
#include <utility>

#include <spdlog/spdlog.h>

namespace impostor {

// The SDK's own logger (client/base/sdk_log.h), which a move logged at debug
// (LogMoves::kDebug, "inside the SDK") goes to, so that it reaches the log
// handler a game set (impostor/log.h) and never the process's default
// logger. Weak: a program without the SDK (the worker) has no such logger
// and logs to the default one.
[[gnu::weak]] spdlog::logger& SdkLog();

namespace {

spdlog::logger& MovesLogger(FailoverChannel::LogMoves log_moves) {
  if (log_moves == FailoverChannel::LogMoves::kDebug && &SdkLog != nullptr) return SdkLog();
  return *spdlog::default_logger_raw();
}

}  // namespace

FailoverChannel::FailoverChannel(std::vector<std::string> targets, MakeChannel make, LogMoves log_moves)
    : targets_(std::move(targets)), make_(std::move(make)), log_moves_(log_moves), failed_(targets_.size(), false) {
  std::lock_guard lock(mu_);
  for (const std::string& target : targets_) channels_.push_back(make_(target));
}

FailoverChannel::Route FailoverChannel::Current() const {
  std::lock_guard lock(mu_);
  return {.index = current_, .channel = channels_[current_]};
}

void FailoverChannel::NoteAnswer(const Route& route) {
  std::lock_guard lock(mu_);
  std::fill(failed_.begin(), failed_.end(), false);
  (void)route;
}

bool FailoverChannel::NoteFailure(const Route& route, grpc::StatusCode code) {
  const bool several = targets_.size() > 1;
  if (code != grpc::StatusCode::UNAVAILABLE && !(several && code == grpc::StatusCode::DEADLINE_EXCEEDED)) {
    return false;
  }
  std::shared_ptr<grpc::Channel> replaced;  // destroyed outside the lock
  std::lock_guard lock(mu_);
  failed_[route.index] = true;
  if (!several) return false;
  if (code == grpc::StatusCode::DEADLINE_EXCEEDED && channels_[route.index] == route.channel) {
    replaced = std::exchange(channels_[route.index], make_(targets_[route.index]));
  }
  if (current_ == route.index) {
    current_ = (current_ + 1) % targets_.size();
    MovesLogger(log_moves_).log(log_moves_ == LogMoves::kInfo ? spdlog::level::info : spdlog::level::debug,
                                "event=server_failover from={} to={} code={}", targets_[route.index],
                                targets_[current_], static_cast<int>(code));
  }
  return !failed_[current_];
}

}  // namespace impostor
