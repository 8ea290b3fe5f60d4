#include "client/cli/flag_terms.h"

#include <cctype>
#include <utility>

namespace impostor::cli {

std::string InFlagTerms(std::string_view message) {
  // The server speaks the API (impostor.v1); a CLI user typed flags. Each
  // field keeps its API name in parentheses, for scripts and the docs.
  static const std::pair<std::string_view, std::string_view> kFields[] = {
      {"parameters.frames", "--frames"},
      {"parameters.resolution", "--resolution"},
      {"parameters.layout", "--layout"},
      {"parameters.ring_views", "--ring"},
      {"parameters.supersampling", "--supersampling"},
      {"parameters.product", "--product"},
      {"parameters.preset", "--preset"},
      {"parameters.point_budget", "--point-budget"},
      {"parameters.lod_ratios", "--lod-ratios"},
      {"parameters.max_planes", "--max-planes"},
      {"parameters.tolerance", "--tolerance"},
      {"parameters.quality_views", "--quality-views"},
      {"parameters.texture_format", "--texture-format"},
      {"parameters.albedo_codec", "--albedo-codec"},
      {"parameters.texture_array", "--array"},
      {"parameters.emissive", "--emissive"},
  };
  static const std::pair<std::string_view, std::string_view> kValues[] = {
      {"PRODUCT_ATLAS", "atlas"},           {"PRODUCT_SURFELS", "surfels"},
      {"PRODUCT_LOD_CHAIN", "lod-chain"},   {"PRODUCT_CARDS", "cards"},
      {"LAYOUT_OCTAHEDRAL", "octahedral"},  {"LAYOUT_HEMI_OCTAHEDRAL", "hemi-octahedral"},
      {"LAYOUT_AZIMUTH_ELEVATION", "azimuth-elevation"}, {"LAYOUT_RING_TOP", "ring-top"},
      {"LAYOUT_BILLBOARD", "billboard"},
  };
  std::string out;
  size_t i = 0;
  while (i < message.size()) {
    bool replaced = false;
    for (const auto& [api, flag] : kFields) {
      // A whole field name: not a prefix of a longer one (parameters.frames_auto).
      if (message.substr(i, api.size()) == api &&
          (i + api.size() == message.size() ||
           !(std::isalnum(static_cast<unsigned char>(message[i + api.size()])) || message[i + api.size()] == '_'))) {
        out.append(flag).append(" (").append(api).append(")");
        i += api.size();
        replaced = true;
        break;
      }
    }
    if (!replaced) {
      for (const auto& [api, word] : kValues) {
        if (message.substr(i, api.size()) == api &&
            (i + api.size() == message.size() ||
             !(std::isalnum(static_cast<unsigned char>(message[i + api.size()])) || message[i + api.size()] == '_'))) {
          out.append(word);
          i += api.size();
          replaced = true;
          break;
        }
      }
    }
    if (!replaced) out += message[i++];
  }
  return out;
}

}  // namespace impostor::cli
