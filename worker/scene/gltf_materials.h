// Converts the glTF materials a scene uses into SceneMaterials and decodes
// the images they reference (each image once, only when used). Internal to
// the glTF loader.
#ifndef IMPOSTOR_WORKER_SCENE_GLTF_MATERIALS_H_
#define IMPOSTOR_WORKER_SCENE_GLTF_MATERIALS_H_

#include <tiny_gltf.h>

#include <glm/mat3x3.hpp>
#include <map>
#include <optional>
#include <tuple>
#include <vector>

#include "absl/status/statusor.h"
#include "worker/scene/gltf_loader.h"
#include "worker/scene/image_predecode.h"
#include "worker/scene/scene.h"

namespace impostor::gltf_internal {

// Builds Scene::materials and Scene::textures on demand, in first-use order.
class MaterialTable {
 public:
  // `model` and `scene` must outlive the table; materials/textures are
  // appended to `scene`.
  // Images in `predecoded` (may be null; must outlive the table) are taken
  // from it rather than decoded.
  MaterialTable(const tinygltf::Model& model, const GltfLoadLimits& limits, Scene* scene,
                PredecodedImages* predecoded = nullptr);

  // Index into scene->materials for glTF material `gltf_index` (-1 = the
  // glTF default material: white, metallic 1, roughness 1), converting it
  // and decoding its textures on first use. INVALID_ARGUMENT for an
  // out-of-range material/texture/image/sampler index, a non-finite factor,
  // a missing or undecodable image; RESOURCE_EXHAUSTED when a texture limit
  // is hit. Images in formats other than PNG and JPEG (KTX2, WebP, DDS, GIF,
  // BMP, ...) are dropped with a warning: the material keeps its factors.
  absl::StatusOr<int> Use(int gltf_index);

  // Whether any material converted so far reads TEXCOORD_1.
  bool uses_uv1() const { return uses_uv1_; }

  // Appends `warning` to scene->warnings unless it is already there.
  void AddWarning(std::string warning);

 private:
  absl::StatusOr<int> Convert(int gltf_index);
  // One texture reference of a material: resolves its UV set (texCoord,
  // KHR_texture_transform with its texCoord override) into out->uv[slot]
  // and returns the scene texture (-1 when none or dropped).
  absl::StatusOr<int> UseSlot(int texture, int tex_coord, const tinygltf::ExtensionMap& extensions,
                              bool srgb, int material, TextureSlot slot, SceneMaterial* out);
  absl::StatusOr<int> UseTexture(int texture, bool srgb, int material, const char* slot);

  const tinygltf::Model& model_;
  const GltfLoadLimits& limits_;
  Scene* scene_;
  std::map<int, int> materials_;  // glTF material (-1 = default) -> scene index
  bool uses_uv1_ = false;
  // (image, wrap_s, wrap_t, srgb) -> scene texture
  std::map<std::tuple<int, int, int, bool>, int> textures_;
  std::map<int, int> decoded_;  // image -> a scene texture holding its pixels
  uint64_t texture_bytes_ = 0;
  PredecodedImages* predecoded_;
};

}  // namespace impostor::gltf_internal

#endif  // IMPOSTOR_WORKER_SCENE_GLTF_MATERIALS_H_
