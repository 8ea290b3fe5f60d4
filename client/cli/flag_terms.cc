#include "client/cli/flag_terms.h"

#include <cctype>
#include <utility>

namespace impostor::cli {
namespace {

bool IsNameChar(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

// `token` at `i` as a whole name: not part of a longer one
// (parameters.frames_auto, x.texture_array, PRODUCT_CARDSX).
bool WholeNameAt(std::string_view message, size_t i, std::string_view token) {
  if (message.substr(i, token.size()) != token) return false;
  if (i > 0 && (IsNameChar(message[i - 1]) || message[i - 1] == '.')) return false;
  const size_t end = i + token.size();
  return end == message.size() || !IsNameChar(message[end]);
}

}  // namespace

std::string InFlagTerms(std::string_view message) {
  // The server speaks the API (impostor.v1); a CLI user typed flags. Each
  // field keeps its API name in parentheses, for scripts and the docs.
  // A longer name comes before a name it starts with.
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
      {"parameters.lod_pixel_error", "--lod-pixel-error"},
      {"parameters.max_planes", "--max-planes"},
      {"parameters.tolerance", "--tolerance"},
      {"parameters.quality_views", "--quality-views"},
      {"parameters.texture_format", "--texture-format"},
      {"parameters.albedo_codec", "--albedo-codec"},
      {"parameters.texture_array", "--array"},
      {"parameters.emissive", "--emissive"},
      // --frames auto's target: the same flags as the gate.
      {"parameters.auto_target.min_iou", "--min-iou"},
      {"parameters.auto_target.min_psnr_db", "--min-psnr"},
      {"parameters.auto_target", "--min-iou/--min-psnr"},
      // The quality gate (SubmitBakeRequest.gate).
      {"gate.min_iou", "--min-iou"},
      {"gate.min_psnr_db", "--min-psnr"},
      {"required_tags", "--require-tag"},
  };
  // Enum values and bare field names, as the flag and value typed.
  static const std::pair<std::string_view, std::string_view> kValues[] = {
      {"PRODUCT_ATLAS", "atlas"},           {"PRODUCT_SURFELS", "surfels"},
      {"PRODUCT_LOD_CHAIN", "lod-chain"},   {"PRODUCT_CARDS", "cards"},
      {"LAYOUT_OCTAHEDRAL", "octahedral"},  {"LAYOUT_HEMI_OCTAHEDRAL", "hemi-octahedral"},
      {"LAYOUT_AZIMUTH_ELEVATION", "azimuth-elevation"}, {"LAYOUT_RING_TOP", "ring-top"},
      {"LAYOUT_BILLBOARD", "billboard"},
      {"TEXTURE_FORMAT_PNG", "--texture-format png"},     {"TEXTURE_FORMAT_KTX2", "--texture-format ktx2"},
      {"ALBEDO_CODEC_UASTC_RDO", "uastc-rdo"},            {"ALBEDO_CODEC_UASTC", "uastc"},
      {"texture_array", "--array"},         {"frames_auto", "--frames auto"},
  };
  std::string out;
  size_t i = 0;
  while (i < message.size()) {
    bool replaced = false;
    for (const auto& [api, flag] : kFields) {
      if (WholeNameAt(message, i, api)) {
        out.append(flag).append(" (").append(api).append(")");
        i += api.size();
        replaced = true;
        break;
      }
    }
    // The gate as a whole ("gate: only atlas and lod-chain bakes are
    // gated"): a field at the start of a clause, not "quality gate".
    static constexpr std::string_view kGate = "gate:";
    if (!replaced && message.substr(i, kGate.size()) == kGate &&
        (i == 0 || (i >= 2 && message.substr(i - 2, 2) == ": "))) {
      out.append("--min-iou/--min-psnr (gate):");
      i += kGate.size();
      replaced = true;
    }
    if (!replaced) {
      for (const auto& [api, word] : kValues) {
        if (WholeNameAt(message, i, api)) {
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
