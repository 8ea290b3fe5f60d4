#include "tests/support/result_digest.h"

#include <nlohmann/json.hpp>

#include "common/util/sha256.h"
#include "tests/support/server_process.h"

namespace impostor::testing {

std::map<std::string, std::string> HashResultDir(const std::filesystem::path& dir) {
  std::map<std::string, std::string> out;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
    if (!entry.is_regular_file()) continue;
    std::string bytes = ReadFileBytes(entry.path());
    if (entry.path().filename() == "manifest.json") {
      nlohmann::json manifest = nlohmann::json::parse(bytes, nullptr, /*allow_exceptions=*/false);
      if (manifest.is_object()) manifest.erase("timings_seconds");
      bytes = manifest.dump();
    }
    out[entry.path().filename().string()] = Sha256Hex(bytes);
  }
  return out;
}

}  // namespace impostor::testing
