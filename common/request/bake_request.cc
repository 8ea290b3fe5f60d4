#include "common/request/bake_request.h"

#include <algorithm>
#include <set>
#include <vector>

#include "absl/strings/str_cat.h"
#include "common/request/auto_frames_ladder.h"
#include "common/request/layout_parameters.h"
#include "common/request/card_parameters.h"
#include "common/request/input_paths.h"
#include "common/request/lod_parameters.h"
#include "common/util/utf8.h"
#include "common/request/quality_parameters.h"
#include "common/request/texture_format_parameters.h"
#include "common/util/sha256.h"

namespace impostor {
namespace {

// A caller's string in an error message: at most 80 bytes of it (a status
// travels in a header with a size limit), valid UTF-8.
std::string Shown(std::string_view value) {
  std::string shown = ValidUtf8(Utf8Prefix(value, 80));
  if (value.size() > 80) shown += "...";
  return shown;
}

bool EndsWithIgnoreCase(std::string_view s, std::string_view suffix) {
  if (s.size() < suffix.size()) return false;
  for (size_t i = 0; i < suffix.size(); ++i) {
    if (std::tolower(static_cast<unsigned char>(s[s.size() - suffix.size() + i])) != suffix[i]) {
      return false;
    }
  }
  return true;
}

absl::Status CheckRange(std::string_view field, uint32_t value, uint32_t lo, uint32_t hi) {
  if (value < lo || value > hi) {
    return absl::InvalidArgumentError(absl::StrCat(std::string(field), ": ", value,
                                                   " is out of range ", lo, "..", hi));
  }
  return absl::OkStatus();
}

absl::Status ValidateInputFile(std::string_view field, const v1::InputFile& file) {
  if (auto s = ValidateRelativePath(absl::StrCat(std::string(field), ".path"), file.path()); !s.ok()) {
    return s;
  }
  if (!file.has_digest()) {
    return absl::InvalidArgumentError(absl::StrCat(std::string(field), ".digest: required"));
  }
  return ValidateDigest(absl::StrCat(std::string(field), ".digest"), file.digest().hash(),
                        file.digest().size_bytes());
}

}  // namespace

std::string_view BakerVersion() { return IMPOSTOR_BAKER_VERSION; }

absl::StatusOr<v1::BakeParameters> NormalizeParameters(const v1::BakeParameters& in) {
  v1::BakeParameters out = in;
  switch (in.product()) {
    case v1::PRODUCT_UNSPECIFIED: out.set_product(v1::PRODUCT_ATLAS); break;
    case v1::PRODUCT_ATLAS:
    case v1::PRODUCT_SURFELS:
    case v1::PRODUCT_CARDS:
    case v1::PRODUCT_LOD_CHAIN: break;
    default:
      return absl::InvalidArgumentError(absl::StrCat(
          "parameters.product: unknown value ", static_cast<int>(in.product()),
          "; expected PRODUCT_ATLAS (1), PRODUCT_SURFELS (2), PRODUCT_CARDS (3) or PRODUCT_LOD_CHAIN (4)"));
  }
  // Every product but surfels refuses the surfel fields.
  if (out.product() != v1::PRODUCT_SURFELS) {
    if (!in.preset().empty()) {
      return absl::InvalidArgumentError(absl::StrCat("parameters.preset: \"", Shown(in.preset()),
                                                     "\" is only for product PRODUCT_SURFELS"));
    }
    if (in.has_point_budget()) {
      return absl::InvalidArgumentError("parameters.point_budget: only for product PRODUCT_SURFELS");
    }
  } else {
    const std::string name = in.preset().empty() ? std::string(kDefaultSurfelPreset) : in.preset();
    const SurfelPreset* preset = nullptr;
    for (const SurfelPreset& p : kSurfelPresets) {
      if (name == p.name) preset = &p;
    }
    if (preset == nullptr) {
      return absl::InvalidArgumentError(absl::StrCat("parameters.preset: unknown preset \"", Shown(name),
                                                     "\"; expected prop, building, vegetation or hero"));
    }
    if (!out.has_point_budget()) out.set_point_budget(preset->point_budget);
    if (out.frames() == 0) out.set_frames(preset->frames);
    if (out.resolution() == 0) out.set_resolution(preset->resolution);
    out.clear_preset();
    if (auto s = CheckRange("parameters.point_budget", out.point_budget(), kMinPointBudget, kMaxPointBudget);
        !s.ok()) {
      return s;
    }
  }
  // The emissive map is a fourth atlas map; other products have no atlas
  // maps of their own to add it to.
  if (in.emissive() && out.product() != v1::PRODUCT_ATLAS) {
    return absl::InvalidArgumentError("parameters.emissive: only for product PRODUCT_ATLAS");
  }
  if (auto s = NormalizeLodParameters(in, &out); !s.ok()) return s;
  if (auto s = NormalizeCardParameters(in, &out); !s.ok()) return s;
  switch (in.layout()) {
    case v1::LAYOUT_UNSPECIFIED:
      // A LOD chain's impostor is seen from around and above, as a game's
      // distant props are: the hemisphere spends its frames there.
      out.set_layout(out.product() == v1::PRODUCT_LOD_CHAIN ? v1::LAYOUT_HEMI_OCTAHEDRAL
                                                             : v1::LAYOUT_OCTAHEDRAL);
      break;
    case v1::LAYOUT_OCTAHEDRAL:
    case v1::LAYOUT_HEMI_OCTAHEDRAL:
    case v1::LAYOUT_AZIMUTH_ELEVATION:
    case v1::LAYOUT_RING_TOP:
    case v1::LAYOUT_BILLBOARD: break;
    default:
      return absl::InvalidArgumentError(absl::StrCat(
          "parameters.layout: unknown value ", static_cast<int>(in.layout()),
          "; expected LAYOUT_OCTAHEDRAL (1), LAYOUT_HEMI_OCTAHEDRAL (2), LAYOUT_AZIMUTH_ELEVATION (3), "
          "LAYOUT_RING_TOP (4) or LAYOUT_BILLBOARD (5)"));
  }
  if (auto s = NormalizeLayoutFrames(&out); !s.ok()) return s;
  if (auto s = NormalizeQualityParameters(in, &out); !s.ok()) return s;
  // frames_auto: the baker picks frames from a ladder that fits the
  // resolution; the checks below see the ladder's smallest grid side, and
  // frames (and ring-top's ring_views, the count its ladder turns) go back
  // to unset at the end.
  if (out.frames_auto()) out.set_frames(AutoFramesMinGridSide(out.layout()));
  if (out.frames() == 0) out.set_frames(kDefaultFrames);
  if (out.resolution() == 0) out.set_resolution(kDefaultResolution);
  if (auto s = CheckRange("parameters.frames", out.frames(), kMinFrames, kMaxFrames); !s.ok()) return s;
  if (auto s = CheckRange("parameters.resolution", out.resolution(), kMinResolution, kMaxResolution);
      !s.ok()) {
    return s;
  }
  if (out.resolution() / out.frames() < kMinTilePixels) {
    return absl::InvalidArgumentError(absl::StrCat(
        "parameters.resolution: ", out.resolution(), " px for ", out.frames(), "x", out.frames(),
        " frames leaves ", out.resolution() / out.frames(), " px per frame; at least ",
        kMinTilePixels, " are needed (resolution >= ", kMinTilePixels * out.frames(), ")"));
  }
  if (auto s = NormalizeSupersampling(&out); !s.ok()) return s;
  if (auto s = NormalizeTextureFormat(in, &out); !s.ok()) return s;
  if (out.frames_auto()) {
    out.set_frames(0);
    if (out.layout() == v1::LAYOUT_RING_TOP) out.clear_ring_views();
  }
  return out;
}

absl::Status ValidateRelativePath(std::string_view field, std::string_view path) {
  const std::string f(field);
  if (path.empty()) return absl::InvalidArgumentError(f + ": required");
  if (path.size() > kMaxPathBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat(f, ": ", path.size(), " bytes is longer than the limit of ", kMaxPathBytes));
  }
  if (path.front() == '/') return absl::InvalidArgumentError(f + ": must be relative, got \"" + std::string(path) + "\"");
  for (char c : path) {
    if (c == '\\' || c == '\0') {
      return absl::InvalidArgumentError(f + ": must use '/' separators and no NUL, got \"" + std::string(path) + "\"");
    }
  }
  size_t start = 0;
  while (start <= path.size()) {
    size_t end = path.find('/', start);
    if (end == std::string_view::npos) end = path.size();
    const std::string_view part = path.substr(start, end - start);
    start = end + 1;
    if (part.empty() || part == "." || part == "..") {
      return absl::InvalidArgumentError(
          f + ": must not contain empty, \".\" or \"..\" components, got \"" + std::string(path) + "\"");
    }
  }
  return absl::OkStatus();
}

absl::Status ValidateMeshInput(const v1::MeshInput& mesh) {
  if (!mesh.has_entry()) return absl::InvalidArgumentError("mesh.entry: required");
  if (auto s = ValidateInputFile("mesh.entry", mesh.entry()); !s.ok()) return s;
  const std::string& entry = mesh.entry().path();
  if (!EndsWithIgnoreCase(entry, ".glb") && !EndsWithIgnoreCase(entry, ".gltf")) {
    return absl::InvalidArgumentError(
        absl::StrCat("mesh.entry.path: \"", entry, "\" is neither a .glb nor a .gltf file"));
  }
  if (mesh.files_size() > kMaxInputFiles) {
    return absl::InvalidArgumentError(absl::StrCat("mesh.files: ", mesh.files_size(),
                                                   " files is more than the limit of ", kMaxInputFiles));
  }
  for (int i = 0; i < mesh.files_size(); ++i) {
    const std::string field = absl::StrCat("mesh.files[", i, "]");
    if (auto s = ValidateInputFile(field, mesh.files(i)); !s.ok()) return s;
  }
  // No two inputs may land on the same place in the worker's input folder.
  return CheckInputPathsDisjoint(mesh);
}

std::string ComputeCacheKey(const v1::MeshInput& mesh, const v1::BakeParameters& p) {
  // Every variable string is length-prefixed so no two different requests
  // can produce the same byte stream.
  std::vector<const v1::InputFile*> files;
  for (const auto& f : mesh.files()) files.push_back(&f);
  std::sort(files.begin(), files.end(),
            [](const v1::InputFile* a, const v1::InputFile* b) { return a->path() < b->path(); });
  Sha256 h;
  auto put = [&h](std::string_view s) {
    h.Update(absl::StrCat(s.size(), ":"));
    h.Update(s);
    h.Update("\n");
  };
  put("impostor.v1 bake");
  put(BakerVersion());
  put(absl::StrCat("entry ", mesh.entry().digest().hash(), " ", mesh.entry().digest().size_bytes()));
  for (const v1::InputFile* f : files) {
    put(f->path());
    put(absl::StrCat(f->digest().hash(), " ", f->digest().size_bytes()));
  }
  put(absl::StrCat("layout ", static_cast<int>(p.layout())));
  put(absl::StrCat("frames ", p.frames()));
  put(absl::StrCat("resolution ", p.resolution()));
  // Only non-default quality-pass settings add a line (quality_parameters.h).
  if (const std::string quality = QualityCacheKeyLine(p); !quality.empty()) put(quality);
  // Only a requested emissive map adds a line: other keys stay as they were.
  if (p.emissive()) put("emissive 1");
  // Layout and sampling settings the frame count does not already imply.
  if (p.has_ring_views()) put(absl::StrCat("ring_views ", p.ring_views()));
  if (p.has_supersampling()) put(absl::StrCat("supersampling ", p.supersampling()));
  if (p.texture_array()) put("texture_array 1");
  // KTX2 only (PNG keys stay as they were): format, codec, encoder version.
  if (const std::string ktx2 = TextureFormatCacheKeyLine(p); !ktx2.empty()) put(ktx2);
  // Atlas keys predate products and stay as they were; other products add
  // their own lines.
  if (p.product() != v1::PRODUCT_ATLAS && p.product() != v1::PRODUCT_UNSPECIFIED) {
    put(absl::StrCat("product ", static_cast<int>(p.product())));
    put(absl::StrCat("point_budget ", p.point_budget()));
    if (p.product() == v1::PRODUCT_LOD_CHAIN) put(LodCacheKeyLine(p));
    if (p.product() == v1::PRODUCT_CARDS) put(CardCacheKeyLine(p));
  }
  return h.FinishHex();
}

}  // namespace impostor
