// The example scene's own graphics pipelines (the mesh's G-buffer pass is
// the worker's BakePipeline, reused as is). One pass after another:
//   shadow map:  mesh_depth (the mesh's positions) + impostor_caster
//                (impostor_runtime_check.vert + impostor_shadow_caster.frag);
//   G-buffer:    the worker's BakePipeline (albedo, normal + depth, ORM);
//   colour:      deferred (lights the G-buffer), ground, impostor_lit
//                (impostor_runtime_check.vert + impostor_material_lit.frag,
//                pixel depth offset on).
// Every pipeline has a 128-byte push-constant block for both stages and no
// vertex input except mesh_depth (SceneVertex positions).
#ifndef IMPOSTOR_EXAMPLES_IMPOSTOR_SCENE_SCENE_PIPELINES_H_
#define IMPOSTOR_EXAMPLES_IMPOSTOR_SCENE_SCENE_PIPELINES_H_

#include <vulkan/vulkan.h>

#include "absl/status/statusor.h"
#include "worker/gpu/vk_handle.h"
#include "worker/gpu/vulkan_context.h"

namespace impostor::example {

inline constexpr VkFormat kShadowFormat = VK_FORMAT_D32_SFLOAT;
inline constexpr VkFormat kColourFormat = VK_FORMAT_R8G8B8A8_SRGB;
inline constexpr uint32_t kPushBytes = 128;

struct ScenePipelines {
  // Set 0 of the colour pass: bindings 0..2 textures (the atlas maps for the
  // impostor, the G-buffer for the deferred pass), 3 shadow map, 4 light
  // uniform, 5 the impostor's instance uniform.
  gpu::UniqueDescriptorSetLayout lit_set;
  // Set 0 of the impostor's shadow caster: bindings 0..1 (albedo, normal+depth).
  gpu::UniqueDescriptorSetLayout caster_set;
  gpu::UniquePipelineLayout lit_layout;
  gpu::UniquePipelineLayout caster_layout;  // also mesh_depth's (no set used)
  gpu::UniquePipeline mesh_depth;
  gpu::UniquePipeline impostor_caster;
  gpu::UniquePipeline deferred;
  gpu::UniquePipeline ground;
  gpu::UniquePipeline impostor_lit;

  // `layout` and `blend_mode` (IMPOSTOR_LAYOUT_*, IMPOSTOR_BLEND_*) are
  // specialization constants of the impostor's two pipelines, `parallax`
  // of the lit one.
  static absl::StatusOr<ScenePipelines> Create(const gpu::VulkanContext& ctx, int layout, int blend_mode,
                                               bool parallax);
};

}  // namespace impostor::example

#endif  // IMPOSTOR_EXAMPLES_IMPOSTOR_SCENE_SCENE_PIPELINES_H_
