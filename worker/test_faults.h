// Test-only fault switch for impostor-worker: lets integration tests make a
// real worker process die on a chosen input, the way a driver crash or a
// mesh that trips a baker bug would (tests/integration/poison_job_test.cc).
//
// Set IMPOSTOR_WORKER_TEST_CRASH_ON=<file name> in the worker's environment
// and the worker raises SIGSEGV when it starts rendering a mesh whose entry
// file has that name. Never set it in production.
#ifndef IMPOSTOR_WORKER_TEST_FAULTS_H_
#define IMPOSTOR_WORKER_TEST_FAULTS_H_

#include <string>

#include "impostor/v1/types.pb.h"

namespace impostor {

// True when `crash_on` is set and names the mesh's entry file.
bool ShouldCrashForTest(const std::string& crash_on, const v1::MeshInput& mesh);

// Dies by SIGSEGV (without a core file). Does not return.
[[noreturn]] void CrashForTest();

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_TEST_FAULTS_H_
