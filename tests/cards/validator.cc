#include "tests/cards/validator.h"

#include <sys/wait.h>

#include <cstdio>

namespace impostor::testing {

ValidatorResult RunGltfValidator(const std::filesystem::path& file) {
  ValidatorResult r;
  // Bounded: `timeout` ends a hung validator (exit 124, reported as a failure).
  const std::string command = std::string("timeout 300 '") + IMPOSTOR_GLTF_VALIDATOR + "' '" + file.string() + "' 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return r;
  char buffer[4096];
  size_t n;
  while ((n = fread(buffer, 1, sizeof(buffer), pipe)) > 0) r.report.append(buffer, n);
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

}  // namespace impostor::testing
