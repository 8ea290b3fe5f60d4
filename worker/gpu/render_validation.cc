#include "worker/gpu/render_validation.h"

#include <cmath>
#include <string>

#include "absl/strings/str_cat.h"

namespace impostor::gpu {
namespace {

std::string TileString(const TileRect& t) {
  return absl::StrCat("(x ", t.x, ", y ", t.y, ", ", t.width, "x", t.height, ")");
}

absl::Status CheckTexture(const Scene& scene, int index, int material, const char* slot) {
  if (index < 0) return absl::OkStatus();
  if (index >= static_cast<int>(scene.textures.size())) {
    return absl::InvalidArgumentError(absl::StrCat("material ", material, " ", slot, " texture ",
                                                   index, " out of range (", scene.textures.size(),
                                                   " textures)"));
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status ValidateRenderRequest(const Scene& scene, const BoundingSphere& sphere,
                                   const std::vector<FrameCamera>& cameras, int atlas_size,
                                   uint32_t max_image_dimension) {
  if (atlas_size <= 0) {
    return absl::InvalidArgumentError(absl::StrCat("atlas size ", atlas_size, " is not positive"));
  }
  if (static_cast<uint32_t>(atlas_size) > max_image_dimension) {
    return absl::InvalidArgumentError(absl::StrCat("atlas size ", atlas_size,
                                                   " exceeds the device's maxImageDimension2D ",
                                                   max_image_dimension));
  }
  if (cameras.empty()) return absl::InvalidArgumentError("no cameras to render");
  for (const FrameCamera& c : cameras) {
    const TileRect& t = c.tile;
    if (t.width <= 0 || t.height <= 0 || t.x < 0 || t.y < 0 ||
        static_cast<int64_t>(t.x) + t.width > atlas_size ||
        static_cast<int64_t>(t.y) + t.height > atlas_size) {
      return absl::InvalidArgumentError(absl::StrCat("frame ", c.index, " tile ", TileString(t),
                                                     " lies outside the ", atlas_size, "x",
                                                     atlas_size, " atlas"));
    }
  }
  if (!(sphere.radius > 0.0f) || !std::isfinite(sphere.radius)) {
    return absl::InvalidArgumentError(
        absl::StrCat("bounding sphere radius ", sphere.radius, " is not positive"));
  }

  if (scene.vertices.empty() || scene.indices.empty() || scene.batches.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("empty scene (", scene.vertices.size(), " vertices, ", scene.indices.size(),
                     " indices, ", scene.batches.size(), " batches)"));
  }
  if (scene.materials.empty()) return absl::InvalidArgumentError("scene has no materials");
  for (size_t i = 0; i < scene.indices.size(); ++i) {
    if (scene.indices[i] >= scene.vertices.size()) {
      return absl::InvalidArgumentError(absl::StrCat("index ", i, " = ", scene.indices[i],
                                                     " out of range (", scene.vertices.size(),
                                                     " vertices)"));
    }
  }
  for (size_t i = 0; i < scene.batches.size(); ++i) {
    const SceneBatch& b = scene.batches[i];
    if (static_cast<uint64_t>(b.first_index) + b.index_count > scene.indices.size() ||
        b.index_count % 3 != 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("batch ", i, " indices [", b.first_index, ", +", b.index_count,
                       ") are not whole triangles inside the ", scene.indices.size(), " indices"));
    }
    if (b.material < 0 || b.material >= static_cast<int>(scene.materials.size())) {
      return absl::InvalidArgumentError(absl::StrCat("batch ", i, " material ", b.material,
                                                     " out of range (", scene.materials.size(),
                                                     " materials)"));
    }
  }
  for (size_t i = 0; i < scene.materials.size(); ++i) {
    const SceneMaterial& m = scene.materials[i];
    const int mi = static_cast<int>(i);
    for (absl::Status s : {CheckTexture(scene, m.base_color_texture, mi, "base colour"),
                           CheckTexture(scene, m.metallic_roughness_texture, mi, "metal-rough"),
                           CheckTexture(scene, m.normal_texture, mi, "normal"),
                           CheckTexture(scene, m.occlusion_texture, mi, "occlusion")}) {
      if (!s.ok()) return s;
    }
  }
  for (size_t i = 0; i < scene.textures.size(); ++i) {
    const SceneTexture& t = scene.textures[i];
    if (t.width <= 0 || t.height <= 0 ||
        t.rgba8.size() != static_cast<size_t>(t.width) * t.height * 4) {
      return absl::InvalidArgumentError(absl::StrCat("texture ", i, " \"", t.name, "\" is ",
                                                     t.width, "x", t.height, " with ",
                                                     t.rgba8.size(), " bytes of RGBA8"));
    }
    if (static_cast<uint32_t>(t.width) > max_image_dimension ||
        static_cast<uint32_t>(t.height) > max_image_dimension) {
      return absl::InvalidArgumentError(
          absl::StrCat("texture ", i, " \"", t.name, "\" is ", t.width, "x", t.height,
                       ", above the device's maxImageDimension2D ", max_image_dimension));
    }
  }
  return absl::OkStatus();
}

}  // namespace impostor::gpu
