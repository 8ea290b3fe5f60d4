// A compute shader with one descriptor set (set 0; binding i = the i-th
// descriptor type given) and one push-constant range, built once and then
// bound and dispatched as often as needed: the runtime view kernel of the
// quality pass (device_impostor_views.h) and the kernels the tests run.
//
// Ownership: owns the pipeline, its layouts and a one-set descriptor pool;
// must be destroyed before the VulkanContext. Thread-safety: one thread;
// Bind rewrites the single set, so the submission that last used it must
// have completed (every user here waits on its submissions).
#ifndef IMPOSTOR_WORKER_GPU_COMPUTE_PIPELINE_H_
#define IMPOSTOR_WORKER_GPU_COMPUTE_PIPELINE_H_

#include <vulkan/vulkan.h>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "worker/gpu/vk_handle.h"
#include "worker/gpu/vulkan_context.h"

namespace impostor::gpu {

// What one binding points at: a storage buffer (`buffer`, whole) or a
// combined image sampler (`view` in SHADER_READ_ONLY_OPTIMAL + `sampler`).
struct ComputeBinding {
  VkDescriptorType type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  VkBuffer buffer = VK_NULL_HANDLE;
  VkImageView view = VK_NULL_HANDLE;
  VkSampler sampler = VK_NULL_HANDLE;
};

class ComputePipeline {
 public:
  // `spirv` is `spirv_bytes` of SPIR-V (a shaders/*_comp.h array) whose
  // entry point is main; `name` labels the pipeline for debuggers.
  static absl::StatusOr<ComputePipeline> Create(const VulkanContext& ctx, const uint32_t* spirv, size_t spirv_bytes,
                                                const std::vector<VkDescriptorType>& bindings, uint32_t push_size,
                                                const char* name);

  ComputePipeline() = default;
  ComputePipeline(ComputePipeline&&) noexcept = default;
  ComputePipeline& operator=(ComputePipeline&&) noexcept = default;

  // Points the set at `bindings` (as many, in the order Create was given)
  // and binds the pipeline and the set into `cmd`.
  void Bind(VkCommandBuffer cmd, const std::vector<ComputeBinding>& bindings) const;
  // Records push_size bytes of push constants from `data`.
  void Push(VkCommandBuffer cmd, const void* data) const;

 private:
  VkDevice device_ = VK_NULL_HANDLE;
  uint32_t push_size_ = 0;
  UniqueDescriptorSetLayout set_layout_;
  UniquePipelineLayout layout_;
  UniquePipeline pipeline_;
  UniqueDescriptorPool pool_;
  VkDescriptorSet set_ = VK_NULL_HANDLE;  // freed with pool_
};

}  // namespace impostor::gpu

#endif  // IMPOSTOR_WORKER_GPU_COMPUTE_PIPELINE_H_
