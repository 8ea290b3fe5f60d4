// Test-only fault switch for impostor-worker: lets integration tests make a
// real worker process die on a chosen input, the way a driver crash or a
// mesh that trips a baker bug would (tests/integration/poison_job_test.cc).
//
// Set in the worker's environment (never in production):
//   IMPOSTOR_WORKER_TEST_CRASH_ON=<file name>: the worker raises SIGSEGV when
//     it starts rendering a mesh whose entry file has that name;
//   IMPOSTOR_WORKER_TEST_FAIL_ON=<file name or *>: every bake of such a mesh
//     (of every mesh for "*") fails with a retryable INTERNAL error, as on a
//     worker with a broken GPU (tests/integration/poison_job_test.cc);
//   IMPOSTOR_WORKER_TEST_HOST_MEMORY=<total bytes>[:<available bytes>]: the
//     bake memory check (bake_memory_check.h) sees this much host memory
//     instead of the machine's, so a small request can be too large
//     (tests/hostile/memory_limit_test.cc).
#ifndef IMPOSTOR_WORKER_TEST_FAULTS_H_
#define IMPOSTOR_WORKER_TEST_FAULTS_H_

#include <optional>
#include <string>

#include "absl/status/status.h"
#include "impostor/v1/types.pb.h"
#include "worker/host_memory.h"

namespace impostor {

// INTERNAL when `fail_on` is "*" or names the mesh's entry file; else OK.
absl::Status FailureForTest(const std::string& fail_on, const v1::MeshInput& mesh);

// True when `crash_on` is set and names the mesh's entry file.
bool ShouldCrashForTest(const std::string& crash_on, const v1::MeshInput& mesh);

// The host memory IMPOSTOR_WORKER_TEST_HOST_MEMORY sets (available = total
// when only one number is given); nullopt when unset. A malformed value is
// logged and ignored.
std::optional<HostMemory> HostMemoryForTest();

// Dies by SIGSEGV (without a core file). Does not return.
[[noreturn]] void CrashForTest();

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_TEST_FAULTS_H_
