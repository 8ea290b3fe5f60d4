// A bake-ready scene: every mesh primitive of the glTF default scene with its
// node transform applied, flattened into one vertex and one index buffer, plus
// the materials and decoded textures they use. Produced by the glTF loader,
// consumed by the GPU renderer. Plain data; no Vulkan, no tinygltf types.
#ifndef IMPOSTOR_WORKER_SCENE_SCENE_H_
#define IMPOSTOR_WORKER_SCENE_SCENE_H_

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <glm/mat3x3.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "worker/scene/texel_buffer.h"

namespace impostor {

// Vertex in scene space (node transforms applied). 72 bytes, tightly packed;
// the GPU vertex layout is this struct (worker/gpu/bake_pipeline.cc).
struct SceneVertex {
  glm::vec3 position{0.0f};
  glm::vec3 normal{0.0f, 1.0f, 0.0f};  // unit
  glm::vec4 tangent{1.0f, 0.0f, 0.0f, 1.0f};  // xyz unit, w = bitangent sign
  glm::vec2 uv{0.0f};                   // TEXCOORD_0 as stored (0 when absent)
  glm::vec2 uv1{0.0f};                  // TEXCOORD_1 as stored (0 when absent)
  glm::vec4 color{1.0f};                // COLOR_0, linear RGBA (1 when absent)
};
static_assert(sizeof(SceneVertex) == 72);

enum class AlphaMode : uint32_t { kOpaque = 0, kMask = 1, kBlend = 2 };

// Texture decoded to 8-bit RGBA, rows top to bottom as in the image file.
struct SceneTexture {
  int width = 0;
  int height = 0;
  TexelBuffer rgba8;  // width * height * 4
  bool srgb = false;           // true for base colour (and emissive) images
  bool has_alpha_channel = true;  // the file has alpha (grey+alpha or RGBA)
  // Sampler, as glTF wrap modes (10497 REPEAT, 33071 CLAMP_TO_EDGE,
  // 33648 MIRRORED_REPEAT).
  int wrap_s = 10497;
  int wrap_t = 10497;
  std::string name;  // for logs
};

// Texture slots of a material, in the order of the bake shader's bindings.
enum TextureSlot : int {
  kSlotBaseColor = 0,
  kSlotMetallicRoughness = 1,
  kSlotNormal = 2,
  kSlotOcclusion = 3,
  kSlotEmissive = 4,
  kTextureSlotCount = 5,
};

// Which UV set a texture slot reads and the KHR_texture_transform applied
// to it: uv' = transform * vec3(uv, 1) (T * R * S, column-major).
struct SlotUv {
  int tex_coord = 0;  // 0 = TEXCOORD_0, 1 = TEXCOORD_1
  glm::mat3 transform{1.0f};
};

// glTF metallic-roughness material. A texture index of -1 means "none".
struct SceneMaterial {
  glm::vec4 base_color_factor{1.0f};
  int base_color_texture = -1;
  float metallic_factor = 1.0f;
  float roughness_factor = 1.0f;
  int metallic_roughness_texture = -1;  // G = roughness, B = metalness
  int normal_texture = -1;
  float normal_scale = 1.0f;
  int occlusion_texture = -1;  // R = occlusion
  float occlusion_strength = 1.0f;
  AlphaMode alpha_mode = AlphaMode::kOpaque;
  float alpha_cutoff = 0.5f;
  bool double_sided = false;
  // Emissive = emissive_texture (sRGB) * emissive_factor * emissive_strength
  // (KHR_materials_emissive_strength), linear.
  glm::vec3 emissive_factor{0.0f};
  int emissive_texture = -1;
  float emissive_strength = 1.0f;
  std::array<SlotUv, kTextureSlotCount> uv{};  // by TextureSlot
  std::string name;
};

// A run of triangles (indices[first_index .. first_index + index_count))
// drawn with one material.
struct SceneBatch {
  uint32_t first_index = 0;
  uint32_t index_count = 0;  // multiple of 3
  int material = 0;          // index into Scene::materials (always valid)
  // Node transform has a negative determinant: the triangle winding is
  // reversed in scene space, so front faces are clockwise.
  bool flipped_winding = false;
};

struct Scene {
  std::vector<SceneVertex> vertices;
  std::vector<uint32_t> indices;       // triangle list into `vertices`
  std::vector<SceneBatch> batches;
  std::vector<SceneMaterial> materials;  // at least one (a default material)
  std::vector<SceneTexture> textures;
  // Axis-aligned bounds of all vertex positions, scene space.
  glm::vec3 bounds_min{0.0f};
  glm::vec3 bounds_max{0.0f};
  // What the loader worked around (skipped points/lines, dropped images,
  // ...), one sentence each; they travel into the manifest's `warnings`.
  std::vector<std::string> warnings;

  size_t TriangleCount() const { return indices.size() / 3; }
};

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_SCENE_SCENE_H_
