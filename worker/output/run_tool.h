// Runs an external tool (the KTX2 encoder) as a child process and waits for
// it. Thread-safe: each call has its own process and log file.
#ifndef IMPOSTOR_WORKER_OUTPUT_RUN_TOOL_H_
#define IMPOSTOR_WORKER_OUTPUT_RUN_TOOL_H_

#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace impostor {

// Runs argv[0] (a path, not searched in PATH) with `argv`, its stdout and
// stderr written to `log`, and returns what it printed. NOT_FOUND if the
// program is not an executable file; INTERNAL naming the program, its exit
// status and the last line it printed if it fails or is killed.
absl::StatusOr<std::string> RunTool(const std::vector<std::string>& argv, const std::filesystem::path& log);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_OUTPUT_RUN_TOOL_H_
