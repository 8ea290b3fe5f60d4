#include "worker/scene/scene_invariants.h"

#include <cstdint>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

absl::Status CheckTexture(const Scene& scene, int index, size_t material, const char* slot) {
  if (index == -1) return absl::OkStatus();
  if (index < -1 || index >= static_cast<int>(scene.textures.size())) {
    return absl::InvalidArgumentError(absl::StrCat("material ", material, " ", slot, " texture ", index,
                                                   " out of range (", scene.textures.size(), " textures)"));
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status CheckSceneInvariants(const Scene& scene) {
  if (scene.vertices.empty() || scene.indices.empty() || scene.batches.empty()) {
    return absl::InvalidArgumentError(absl::StrCat("empty scene (", scene.vertices.size(), " vertices, ",
                                                   scene.indices.size(), " indices, ", scene.batches.size(),
                                                   " batches)"));
  }
  if (scene.materials.empty()) return absl::InvalidArgumentError("scene has no materials");
  if (scene.indices.size() % 3 != 0) {
    return absl::InvalidArgumentError(absl::StrCat(scene.indices.size(), " indices are not whole triangles"));
  }
  for (size_t i = 0; i < scene.indices.size(); ++i) {
    if (scene.indices[i] >= scene.vertices.size()) {
      return absl::InvalidArgumentError(absl::StrCat("index ", i, " = ", scene.indices[i], " out of range (",
                                                     scene.vertices.size(), " vertices)"));
    }
  }
  for (size_t i = 0; i < scene.batches.size(); ++i) {
    const SceneBatch& b = scene.batches[i];
    if (uint64_t{b.first_index} + b.index_count > scene.indices.size() || b.index_count % 3 != 0) {
      return absl::InvalidArgumentError(absl::StrCat("batch ", i, " indices [", b.first_index, ", +",
                                                     b.index_count, ") are not whole triangles inside the ",
                                                     scene.indices.size(), " indices"));
    }
    if (b.material < 0 || b.material >= static_cast<int>(scene.materials.size())) {
      return absl::InvalidArgumentError(absl::StrCat("batch ", i, " material ", b.material, " out of range (",
                                                     scene.materials.size(), " materials)"));
    }
  }
  for (size_t i = 0; i < scene.materials.size(); ++i) {
    const SceneMaterial& m = scene.materials[i];
    for (absl::Status s : {CheckTexture(scene, m.base_color_texture, i, "base colour"),
                           CheckTexture(scene, m.metallic_roughness_texture, i, "metal-rough"),
                           CheckTexture(scene, m.normal_texture, i, "normal"),
                           CheckTexture(scene, m.occlusion_texture, i, "occlusion"),
                           CheckTexture(scene, m.emissive_texture, i, "emissive")}) {
      if (!s.ok()) return s;
    }
    if (m.alpha_mode != AlphaMode::kOpaque && m.alpha_mode != AlphaMode::kMask &&
        m.alpha_mode != AlphaMode::kBlend) {
      return absl::InvalidArgumentError(
          absl::StrCat("material ", i, " alpha mode ", static_cast<uint32_t>(m.alpha_mode), " is unknown"));
    }
  }
  for (size_t i = 0; i < scene.textures.size(); ++i) {
    const SceneTexture& t = scene.textures[i];
    if (t.width <= 0 || t.height <= 0 ||
        t.rgba8.size() != static_cast<uint64_t>(t.width) * static_cast<uint64_t>(t.height) * 4) {
      return absl::InvalidArgumentError(absl::StrCat("texture ", i, " \"", t.name, "\" is ", t.width, "x",
                                                     t.height, " with ", t.rgba8.size(), " bytes of RGBA8"));
    }
  }
  return absl::OkStatus();
}

}  // namespace impostor
