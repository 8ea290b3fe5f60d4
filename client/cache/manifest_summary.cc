#include "client/cache/manifest_summary.h"

#include <nlohmann/json.hpp>

namespace impostor::sdk {

ManifestSummary SummarizeManifest(std::string_view manifest_json) {
  ManifestSummary out;
  const nlohmann::json j = nlohmann::json::parse(manifest_json, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object()) return out;
  if (auto it = j.find("product"); it != j.end() && it->is_string()) out.product = it->get<std::string>();
  if (auto it = j.find("views"); it != j.end() && it->is_array()) out.view_count = static_cast<uint32_t>(it->size());
  // A strip one tile wide and a tile per view high: what the manifest says
  // of texture-array maps (there is no flag of its own).
  const auto tile = j.find("tile_size");
  const auto maps = j.find("maps");
  if (tile != j.end() && tile->is_number_unsigned() && maps != j.end() && maps->is_array() && out.view_count > 1) {
    for (const nlohmann::json& map : *maps) {
      if (!map.is_object() || map.value("semantic", "") != "albedo_alpha") continue;
      const uint64_t t = tile->get<uint64_t>();
      out.texture_array = map.value("width", uint64_t{0}) == t && map.value("height", uint64_t{0}) == t * out.view_count;
    }
  }
  return out;
}

}  // namespace impostor::sdk
