#include "worker/test_faults.h"

#include <signal.h>
#include <sys/resource.h>
#include <unistd.h>

#include <filesystem>

#include <spdlog/spdlog.h>

namespace impostor {

bool ShouldCrashForTest(const std::string& crash_on, const v1::MeshInput& mesh) {
  return !crash_on.empty() && std::filesystem::path(mesh.entry().path()).filename() == crash_on;
}

absl::Status FailureForTest(const std::string& fail_on, const v1::MeshInput& mesh) {
  if (fail_on.empty()) return absl::OkStatus();
  if (fail_on != "*" && std::filesystem::path(mesh.entry().path()).filename() != fail_on) return absl::OkStatus();
  return absl::InternalError("test fault: IMPOSTOR_WORKER_TEST_FAIL_ON=" + fail_on);
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
