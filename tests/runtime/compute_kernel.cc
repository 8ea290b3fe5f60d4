#include "tests/runtime/compute_kernel.h"

#include "worker/gpu/barriers.h"
#include "worker/gpu/command_runner.h"
#include "worker/gpu/compute_pipeline.h"
#include "worker/gpu/sampled_image_upload.h"
#include "worker/gpu/vk_check.h"

namespace impostor::testing {

absl::Status RunKernel(const gpu::VulkanContext& ctx, const uint32_t* spirv, size_t spirv_bytes,
                       const std::vector<KernelBinding>& bindings, const void* push, uint32_t push_size,
                       uint32_t groups_x, uint32_t groups_y) {
  std::vector<VkDescriptorType> types;
  for (const KernelBinding& b : bindings) types.push_back(b.type);
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(gpu::ComputePipeline pipeline,
                                gpu::ComputePipeline::Create(ctx, spirv, spirv_bytes, types, push_size, "test kernel"));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(gpu::CommandRunner runner, gpu::CommandRunner::Create(ctx));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(VkCommandBuffer cmd, runner.Begin());
  pipeline.Bind(cmd, bindings);
  pipeline.Push(cmd, push);
  vkCmdDispatch(cmd, groups_x, groups_y, 1);
  gpu::MemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
  return runner.SubmitAndWait();
}

absl::StatusOr<gpu::GpuImage> UploadImage(const gpu::VulkanContext& ctx, VkFormat format, uint32_t width,
                                          uint32_t height, const void* data, size_t bytes) {
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(gpu::CommandRunner runner, gpu::CommandRunner::Create(ctx));
  return gpu::UploadSampledImage(ctx, runner, format, width, height, data, bytes, "runtime test image");
}

}  // namespace impostor::testing
