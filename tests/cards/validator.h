// Runs the Khronos glTF validator (tools/gltf_validator/validate.sh, path
// from the IMPOSTOR_GLTF_VALIDATOR compile definition) on a file.
#ifndef IMPOSTOR_TESTS_CARDS_VALIDATOR_H_
#define IMPOSTOR_TESTS_CARDS_VALIDATOR_H_

#include <filesystem>
#include <string>

namespace impostor::testing {

struct ValidatorResult {
  int exit_code = -1;   // 0 = no errors
  std::string report;   // the validator's JSON report (and stderr)
};

ValidatorResult RunGltfValidator(const std::filesystem::path& file);

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_CARDS_VALIDATOR_H_
