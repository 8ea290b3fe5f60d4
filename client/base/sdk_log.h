// The SDK's own logger (impostor/log.h): every line libimpostor.so writes
// goes through SdkLog(), never through spdlog's default logger, which
// belongs to the process (a game that uses spdlog shares the one
// libspdlog.so with us). Its one sink hands each line to the handler set by
// SetLogHandler, or writes it to stderr.
//
// The logger is not registered with spdlog (spdlog::get does not find it),
// so a game's spdlog::set_level, set_pattern or drop_all leave it alone;
// its level is SetLogHandler's min_level.
#ifndef IMPOSTOR_CLIENT_BASE_SDK_LOG_H_
#define IMPOSTOR_CLIENT_BASE_SDK_LOG_H_

#include <spdlog/logger.h>

namespace impostor {

// Created on first use and never destroyed (SDK threads may still log while
// the process exits). Not in impostor::sdk, so libimpostor.so does not
// export it (cmake/impostor_sdk.map). common/net/failover_channel.cc refers to
// it weakly: the SDK's failover lines come here, the worker's stay on the
// default logger.
spdlog::logger& SdkLog();

}  // namespace impostor

#endif  // IMPOSTOR_CLIENT_BASE_SDK_LOG_H_
