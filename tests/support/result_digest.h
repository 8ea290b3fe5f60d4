// Compares baked results across runs: the digest of every file of a result
// directory, so a result that went through an outage or a cut connection can
// be held byte-identical to an uninterrupted bake of the same input.
#ifndef IMPOSTOR_TESTS_SUPPORT_RESULT_DIGEST_H_
#define IMPOSTOR_TESTS_SUPPORT_RESULT_DIGEST_H_

#include <filesystem>
#include <map>
#include <string>

namespace impostor::testing {

// The SHA-256 of every file of a result directory, by file name. For
// manifest.json, of its JSON without "timings_seconds": the only part of a
// result that differs between two bakes of the same input (every map is
// byte-identical).
std::map<std::string, std::string> HashResultDir(const std::filesystem::path& dir);

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_SUPPORT_RESULT_DIGEST_H_
