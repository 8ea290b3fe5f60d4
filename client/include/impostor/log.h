// Where the SDK's log lines go (libimpostor.so: client.h, cache.h and the C
// API of impostor_c.h, which has the same control as
// impostor_set_log_handler).
//
// The SDK says a few things a game may want in its own log: a cached result
// found damaged and fetched again, an unreadable cache entry dropped (at
// kWarning), retries, resumed downloads and failovers (at kDebug). By
// default they are written to stderr at kWarning and above, one line each
// ("[time] [impostor-sdk] [warning] cache: <key> is damaged (...); fetching
// it again"). The SDK never writes to the process's spdlog default logger,
// so a game that uses spdlog itself keeps its logger, its levels and its
// sinks to itself.
//
// To put the lines into the game's log instead, or to silence them:
//
//   impostor::sdk::SetLogHandler(
//       [](impostor::sdk::LogLevel level, std::string_view message) {
//         MyEngineLog(level >= impostor::sdk::LogLevel::kWarning, message);
//       },
//       impostor::sdk::LogLevel::kInfo);
//   impostor::sdk::SetLogHandler(nullptr, impostor::sdk::LogLevel::kOff);  // nothing at all
//   impostor::sdk::SetLogHandler(nullptr);                                   // the default again
//
// The setting is process-wide (one for every Cache and Client, and the C
// API) and may be changed at any time, from any thread.
#ifndef IMPOSTOR_CLIENT_INCLUDE_IMPOSTOR_LOG_H_
#define IMPOSTOR_CLIENT_INCLUDE_IMPOSTOR_LOG_H_

#include <functional>
#include <string_view>

namespace impostor::sdk {

// How much a line matters; also the least level SetLogHandler passes on.
// The values are those of impostor_c.h's IMPOSTOR_LOG_* constants.
enum class LogLevel {
  kDebug = 0,    // retries, resumed transfers, failovers: for chasing a problem
  kInfo = 1,     // (the SDK has none today)
  kWarning = 2,  // something went wrong and was dealt with (damaged cache entry, fetched again)
  kError = 3,    // (the SDK has none today: failures are returned as Status)
  kOff = 4,      // as min_level: no line at all
};

// Receives one line: its level (never kOff) and its text, without a
// timestamp or a trailing newline. The view is valid only during the call.
using LogHandler = std::function<void(LogLevel level, std::string_view message)>;

// Sends every SDK line at `min_level` or above to `handler`; lines below it
// are dropped before they are formatted. A null `handler` restores the
// default destination, stderr, with `min_level` still applying
// (SetLogHandler(nullptr, LogLevel::kOff) silences the SDK;
// SetLogHandler(nullptr) is the default of a program that never calls this).
//
// Threads: the handler is called on whichever thread logs, which is often
// one of the SDK's own (a cache's download and I/O threads, GetAsync's
// callbacks, gRPC's threads), so it must be thread-safe with respect to the
// rest of the game; calls are never concurrent with each other (the SDK
// makes them one at a time). Once SetLogHandler returns, the handler it
// replaced is not running and is never called again, except when
// SetLogHandler is called from inside that handler (then the call under way
// finishes). The handler may call SetLogHandler; it must not wait for
// another thread that logs or calls SetLogHandler (so no blocking SDK call
// such as Cache::Get from inside it: the thread it would wait for may be
// waiting to log), and should not block for long (a slow handler slows
// every SDK thread that logs). An exception thrown by the handler is
// swallowed and the line is lost.
void SetLogHandler(LogHandler handler, LogLevel min_level = LogLevel::kWarning);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_INCLUDE_IMPOSTOR_LOG_H_
