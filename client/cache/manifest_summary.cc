#include "client/cache/manifest_summary.h"

#include <nlohmann/json.hpp>

namespace impostor::sdk {

ManifestSummary SummarizeManifest(std::string_view manifest_json) {
  ManifestSummary out;
  const nlohmann::json j = nlohmann::json::parse(manifest_json, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object()) return out;
  if (auto it = j.find("product"); it != j.end() && it->is_string()) out.product = it->get<std::string>();
  if (auto it = j.find("views"); it != j.end() && it->is_array()) out.view_count = static_cast<uint32_t>(it->size());
  return out;
}

}  // namespace impostor::sdk
