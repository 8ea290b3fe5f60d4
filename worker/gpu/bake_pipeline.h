// The one graphics pipeline of the bake (shaders/bake.vert + bake.frag) and
// its layouts: dynamic rendering into the three atlas formats + D32 depth,
// depth test LESS, no blending. Viewport, scissor, cull mode and front face
// are dynamic, so every tile and every batch (single/double-sided, flipped
// winding) uses the same pipeline.
//
// Resource interface:
//   push constants: bytes 0..63 vertex (frame view-projection),
//                   bytes 64..111 fragment (MaterialPushConstants)
//   set 0: bindings 0..4 combined image samplers (base colour, metal-rough,
//          normal, occlusion, emissive), binding 5 uniform buffer
//          (MaterialUniforms: per-slot UV set and transform), fragment
//          stage; one set per material.
//
// Ownership: owns the pipeline, pipeline layout and set layout; must be
// destroyed before the VulkanContext. Thread-safety: immutable after Create.
#ifndef IMPOSTOR_WORKER_GPU_BAKE_PIPELINE_H_
#define IMPOSTOR_WORKER_GPU_BAKE_PIPELINE_H_

#include <vulkan/vulkan.h>

#include <cstdint>
#include <glm/vec4.hpp>

#include "absl/status/statusor.h"
#include "worker/gpu/vk_handle.h"
#include "worker/gpu/vulkan_context.h"
#include "worker/scene/scene.h"

namespace impostor::gpu {

inline constexpr uint32_t kFramePushOffset = 0;
inline constexpr uint32_t kFramePushSize = 64;  // mat4
inline constexpr uint32_t kMaterialPushOffset = 64;
inline constexpr uint32_t kMaterialTextureCount = 5;
inline constexpr uint32_t kMaterialUniformBinding = 5;

// Mirrors `MaterialPush` in shaders/bake.frag (std430 push-constant layout).
struct MaterialPushConstants {
  glm::vec4 base_color_factor{1.0f};
  float metallic_factor = 1.0f;
  float roughness_factor = 1.0f;
  float normal_scale = 1.0f;
  float occlusion_strength = 1.0f;
  float alpha_cutoff = 0.5f;
  uint32_t alpha_mode = 0;
  uint32_t has_normal_map = 0;
  uint32_t pad = 0;
};
static_assert(sizeof(MaterialPushConstants) == 48);
static_assert(kMaterialPushOffset + sizeof(MaterialPushConstants) <= 128,
              "128 bytes is the guaranteed maxPushConstantsSize");

MaterialPushConstants MakeMaterialPushConstants(const SceneMaterial& material);

// Mirrors `MaterialUniform` in shaders/bake.frag (std140): per texture slot
// (TextureSlot order) the two rows of its 2x3 affine UV transform, row0.w =
// UV set; then the emissive factor x strength.
struct MaterialUniforms {
  glm::vec4 row0[kTextureSlotCount];
  glm::vec4 row1[kTextureSlotCount];
  glm::vec4 emissive{0.0f};
};
static_assert(sizeof(MaterialUniforms) == 176);

MaterialUniforms MakeMaterialUniforms(const SceneMaterial& material);

class BakePipeline {
 public:
  static absl::StatusOr<BakePipeline> Create(const VulkanContext& ctx);

  BakePipeline() = default;
  BakePipeline(BakePipeline&&) noexcept = default;
  BakePipeline& operator=(BakePipeline&&) noexcept = default;

  VkPipeline pipeline() const { return pipeline_.get(); }
  VkPipelineLayout layout() const { return layout_.get(); }
  VkDescriptorSetLayout set_layout() const { return set_layout_.get(); }

 private:
  UniqueDescriptorSetLayout set_layout_;
  UniquePipelineLayout layout_;
  UniquePipeline pipeline_;
};

}  // namespace impostor::gpu

#endif  // IMPOSTOR_WORKER_GPU_BAKE_PIPELINE_H_
