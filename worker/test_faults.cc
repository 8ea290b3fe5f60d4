#include "worker/test_faults.h"

#include <signal.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <vector>

#include <spdlog/spdlog.h>

#include "absl/strings/numbers.h"
#include "absl/strings/str_split.h"

namespace impostor {

bool ShouldCrashForTest(const std::string& crash_on, const v1::MeshInput& mesh) {
  return !crash_on.empty() && std::filesystem::path(mesh.entry().path()).filename() == crash_on;
}

absl::Status FailureForTest(const std::string& fail_on, const v1::MeshInput& mesh) {
  if (fail_on.empty()) return absl::OkStatus();
  if (fail_on != "*" && std::filesystem::path(mesh.entry().path()).filename() != fail_on) return absl::OkStatus();
  return absl::InternalError("test fault: IMPOSTOR_WORKER_TEST_FAIL_ON=" + fail_on);
}

std::optional<HostMemory> HostMemoryForTest() {
  constexpr char kVariable[] = "IMPOSTOR_WORKER_TEST_HOST_MEMORY";
  const char* value = std::getenv(kVariable);
  if (value == nullptr || *value == '\0') return std::nullopt;
  const std::vector<absl::string_view> parts = absl::StrSplit(value, ':');
  HostMemory memory{.total_bound = kVariable, .available_bound = kVariable};
  if (parts.size() > 2 || !absl::SimpleAtoi(parts[0], &memory.total_bytes) ||
      !absl::SimpleAtoi(parts.back(), &memory.available_bytes)) {
    spdlog::warn("event=test_host_memory_ignored value=\"{}\" reason=\"expected TOTAL[:AVAILABLE] bytes\"", value);
    return std::nullopt;
  }
  return memory;
}

void CrashForTest() {
  spdlog::warn("event=test_crash signal=SIGSEGV reason=IMPOSTOR_WORKER_TEST_CRASH_ON");
  spdlog::default_logger()->flush();
  // A core file of a Vulkan process is large and slow to write.
  const rlimit no_core{0, 0};
  ::setrlimit(RLIMIT_CORE, &no_core);
  ::signal(SIGSEGV, SIG_DFL);
  ::raise(SIGSEGV);
  ::_exit(128 + SIGSEGV);  // not reached
}

}  // namespace impostor
