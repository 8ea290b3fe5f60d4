// Runs an external tool (the KTX2 encoder) as a child process and waits for
// it. Thread-safe: each call has its own process and log file.
#ifndef IMPOSTOR_WORKER_OUTPUT_RUN_TOOL_H_
#define IMPOSTOR_WORKER_OUTPUT_RUN_TOOL_H_

#include <atomic>
#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace impostor {

// Runs argv[0] (a path, not searched in PATH) with `argv`, its stdout and
// stderr written to `log`, and returns what it printed. NOT_FOUND if the
// program is not an executable file; INTERNAL naming the program, its exit
// status and the last line it printed if it fails or is killed. While it
// runs, `*cancelled` (may be null) is checked at least every 100 ms: once it
// is true the tool is killed and reaped and the call returns CANCELLED (an
// encoder can run for minutes; a cancelled job must not wait for it).
absl::StatusOr<std::string> RunTool(const std::vector<std::string>& argv, const std::filesystem::path& log,
                                    const std::atomic<bool>* cancelled = nullptr);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_OUTPUT_RUN_TOOL_H_
