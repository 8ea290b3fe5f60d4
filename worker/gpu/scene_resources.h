// Device-side copy of one Scene for Render(): vertex and index buffers,
// textures (with mips), samplers, and one descriptor set per material whose
// five texture slots always hold something (1x1 white or flat-normal
// defaults stand in for missing textures).
//
// Ownership: owns every resource it created; destruction frees the
// descriptor pool first, then samplers, textures and buffers. The owner must
// have waited for the last submission that used them. Thread-safety: none.
#ifndef IMPOSTOR_WORKER_GPU_SCENE_RESOURCES_H_
#define IMPOSTOR_WORKER_GPU_SCENE_RESOURCES_H_

#include <vulkan/vulkan.h>

#include <map>
#include <memory>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "worker/gpu/bake_pipeline.h"
#include "worker/gpu/command_runner.h"
#include "worker/gpu/gpu_buffer.h"
#include "worker/gpu/staging_uploader.h"
#include "worker/gpu/texture_filter.h"
#include "worker/gpu/vk_handle.h"
#include "worker/gpu/vulkan_context.h"
#include "worker/scene/scene.h"

namespace impostor::gpu {

class SceneResources {
 public:
  // Uploads `scene` (already validated) and waits for the copies to finish.
  // Every sampler filters as `filter` says (texture_filter.h).
  static absl::StatusOr<std::unique_ptr<SceneResources>> Upload(const VulkanContext& ctx,
                                                                CommandRunner& runner,
                                                                const BakePipeline& pipeline,
                                                                const Scene& scene,
                                                                const TextureFilter& filter);

  // Rebinds every material to samplers that filter as `filter` says, keeping
  // the uploaded buffers and textures (nothing is copied again); a no-op
  // when the filter is unchanged. `scene` must be the uploaded one, and no
  // submission may still use the old sets (the device idle).
  absl::Status UseFilter(const VulkanContext& ctx, const BakePipeline& pipeline, const Scene& scene,
                         const TextureFilter& filter);

  VkBuffer vertex_buffer() const { return vertices_.buffer(); }
  VkBuffer index_buffer() const { return indices_.buffer(); }
  VkDescriptorSet material_set(int material) const { return material_sets_[material]; }
  VkDeviceSize uploaded_bytes() const { return uploaded_bytes_; }

 private:
  SceneResources() = default;
  absl::StatusOr<VkSampler> SamplerFor(const VulkanContext& ctx, int wrap_s, int wrap_t);
  // Samplers (filter_), the descriptor pool and one set per material.
  absl::Status BindMaterials(const VulkanContext& ctx, const BakePipeline& pipeline, const Scene& scene);

  TextureFilter filter_;
  GpuBuffer vertices_;
  GpuBuffer indices_;
  GpuBuffer material_uniforms_;  // MaterialUniforms per material, aligned
  VkDeviceSize uniform_stride_ = 0;
  std::vector<UploadedTexture> textures_;
  UploadedTexture white_;        // base colour, metal-rough, occlusion default
  UploadedTexture flat_normal_;  // (128,128,255): tangent-space +Z
  std::map<std::pair<int, int>, UniqueSampler> samplers_;  // by glTF wrap s, t
  UniqueDescriptorPool descriptor_pool_;                   // destroyed first
  std::vector<VkDescriptorSet> material_sets_;             // freed with the pool
  VkDeviceSize uploaded_bytes_ = 0;
};

}  // namespace impostor::gpu

#endif  // IMPOSTOR_WORKER_GPU_SCENE_RESOURCES_H_
