#include "examples/impostor_scene/baked_impostor.h"

#include <fstream>
#include <sstream>
#include <string>

#include "absl/strings/str_cat.h"
#include "common/manifest/manifest_json.h"
#include "worker/output/map_writer.h"

namespace impostor::example {
namespace {

namespace fs = std::filesystem;

absl::StatusOr<std::string> ReadText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat("'", path.string(), "' does not exist or cannot be read"));
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The GLSL layout number and the ring view count, from the manifest.
absl::Status SetLayout(const v1::Manifest& m, const fs::path& dir, BakedImpostor* out) {
  const int views = m.views_size();
  const int n = static_cast<int>(m.frames());
  auto bad = [&](const std::string& why) {
    return absl::InvalidArgumentError(absl::StrCat(dir.string(), "/manifest.json: ", why));
  };
  switch (m.layout()) {
    case v1::LAYOUT_UNSPECIFIED:
    case v1::LAYOUT_OCTAHEDRAL:
    case v1::LAYOUT_HEMI_OCTAHEDRAL:
    case v1::LAYOUT_AZIMUTH_ELEVATION:
      if (n < 1 || views != n * n) return bad(absl::StrCat("layout needs frames x frames views; frames ", n, ", views ", views));
      out->layout = m.layout() == v1::LAYOUT_UNSPECIFIED ? 0 : static_cast<int>(m.layout()) - 1;
      return absl::OkStatus();
    case v1::LAYOUT_RING_TOP:
      if (views < 2 || views > n * n) return bad(absl::StrCat("ring-top needs 2..frames^2 views; views ", views));
      out->layout = 3;
      out->ring_views = views - 1;
      return absl::OkStatus();
    case v1::LAYOUT_BILLBOARD:
      if (views != 9) return bad(absl::StrCat("billboard needs 9 views; views ", views));
      out->layout = 4;
      out->ring_views = 8;
      return absl::OkStatus();
    default:
      return bad(absl::StrCat("unknown layout ", static_cast<int>(m.layout())));
  }
}

// One PNG map named by `semantic` in the manifest, checked for its bit depth
// and for the atlas size.
absl::StatusOr<PngImage> ReadMap(const v1::Manifest& m, const fs::path& dir, const std::string& semantic,
                                 int bit_depth) {
  for (const v1::MapFile& map : m.maps()) {
    if (map.semantic() != semantic) continue;
    if (map.format().rfind("png_", 0) != 0) {
      return absl::InvalidArgumentError(absl::StrCat(
          dir.string(), ": map '", semantic, "' is ", map.format(),
          "; this example reads PNG maps only (bake with --texture-format png)"));
    }
    absl::StatusOr<PngImage> png = ReadPng(dir / map.file());
    if (!png.ok()) return png.status();
    if (png->bit_depth != bit_depth || png->channels != 4) {
      return absl::InvalidArgumentError(absl::StrCat(dir.string(), "/", map.file(), ": expected RGBA ", bit_depth,
                                                     "-bit, got ", png->channels, " channels of ", png->bit_depth,
                                                     " bits"));
    }
    if (png->width != static_cast<int>(m.resolution()) || png->height != static_cast<int>(m.resolution())) {
      return absl::InvalidArgumentError(absl::StrCat(dir.string(), "/", map.file(), ": ", png->width, "x",
                                                     png->height, " but the manifest's resolution is ",
                                                     m.resolution()));
    }
    return png;
  }
  return absl::NotFoundError(absl::StrCat(dir.string(), "/manifest.json lists no '", semantic, "' map"));
}

}  // namespace

absl::StatusOr<BakedImpostor> LoadBakedImpostor(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    return absl::NotFoundError(absl::StrCat("result directory '", dir.string(), "' does not exist"));
  }
  absl::StatusOr<std::string> json = ReadText(dir / "manifest.json");
  if (!json.ok()) return json.status();
  absl::StatusOr<v1::Manifest> m = ManifestFromJson(*json);
  if (!m.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(dir.string(), "/manifest.json: ", m.status().message()));
  }
  if (m->product() != v1::PRODUCT_UNSPECIFIED && m->product() != v1::PRODUCT_ATLAS) {
    return absl::InvalidArgumentError(absl::StrCat(dir.string(), "/manifest.json: product '",
                                                   std::string(ProductJsonName(m->product())),
                                                   "' is not an atlas impostor; bake with --product atlas"));
  }
  BakedImpostor out;
  if (absl::Status s = SetLayout(*m, dir, &out); !s.ok()) return s;
  out.frames = static_cast<int>(m->frames());
  out.tile_size = static_cast<int>(m->tile_size());
  if (out.tile_size < 1 || m->bounding_sphere().center_size() != 3 || !(m->bounding_sphere().radius() > 0.0f)) {
    return absl::InvalidArgumentError(
        absl::StrCat(dir.string(), "/manifest.json: needs tile_size >= 1 and a bounding_sphere with 3 centre "
                                   "coordinates and a positive radius"));
  }
  for (int i = 0; i < 3; ++i) out.sphere_center[i] = m->bounding_sphere().center(i);
  out.sphere_radius = m->bounding_sphere().radius();
  absl::StatusOr<PngImage> albedo = ReadMap(*m, dir, "albedo_alpha", 8);
  if (!albedo.ok()) return albedo.status();
  absl::StatusOr<PngImage> normal_depth = ReadMap(*m, dir, "normal_depth", 16);
  if (!normal_depth.ok()) return normal_depth.status();
  absl::StatusOr<PngImage> orm = ReadMap(*m, dir, "orm", 8);
  if (!orm.ok()) return orm.status();
  out.width = albedo->width;
  out.height = albedo->height;
  out.albedo_alpha = std::move(albedo->pixels8);
  out.normal_depth = std::move(normal_depth->pixels16);
  out.orm = std::move(orm->pixels8);
  return out;
}

}  // namespace impostor::example
