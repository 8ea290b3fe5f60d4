// Helpers for tests that start, signal and kill real impostor-worker
// processes next to a ServerProcess: workers with a name and test switches
// in their environment, and watching a job until a condition holds.
#ifndef IMPOSTOR_TESTS_INTEGRATION_FARM_PROCESSES_H_
#define IMPOSTOR_TESTS_INTEGRATION_FARM_PROCESSES_H_

#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <memory>
#include <string>
#include <vector>

#include "tests/support/server_process.h"

namespace impostor::testing {

// impostor-worker --server=<address> --name=<name> [extra...], with `env`
// (e.g. IMPOSTOR_WORKER_TEST_PAUSE_FILE) set in its environment only.
std::unique_ptr<ChildProcess> StartWorker(const std::string& address, const std::string& name,
                                          const std::vector<std::string>& extra = {},
                                          const std::map<std::string, std::string>& env = {});

// Sets environment variables for the lifetime of the object (children
// started meanwhile inherit them), then restores the previous values.
class ScopedEnv {
 public:
  explicit ScopedEnv(std::map<std::string, std::string> vars);
  ~ScopedEnv();
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  std::map<std::string, std::optional<std::string>> saved_;
};

// GetJob; a failed call is a test failure and an empty Job.
v1::Job GetJob(v1::BakeService::Stub& bake, const std::string& job_id);

// Submits `mesh` at a small size (2 frames, 64 px); a failed call is a test
// failure.
v1::SubmitBakeResponse SubmitSmall(v1::BakeService::Stub& bake, const v1::MeshInput& mesh);

// Uploads the model at `glb` and `pad_bytes` random bytes (seeded by
// `seed`) as an extra input file "pad.bin" that the loader never reads but
// a worker must download, and submits both small: a job whose input
// download is long enough to be stopped part-way (TcpProxy).
v1::SubmitBakeResponse SubmitWithPaddedInput(ServerProcess& server, const std::filesystem::path& glb,
                                             size_t pad_bytes, uint32_t seed);

// A loopback port nothing listens on (bound, read, released).
int FreeLoopbackPort();

void Touch(const std::filesystem::path& file);

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_INTEGRATION_FARM_PROCESSES_H_
