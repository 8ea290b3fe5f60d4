#include "tests/runtime/compute_kernel.h"

#include <cstring>

#include "worker/gpu/barriers.h"
#include "worker/gpu/command_runner.h"
#include "worker/gpu/gpu_buffer.h"
#include "worker/gpu/vk_check.h"
#include "worker/gpu/vk_handle.h"

namespace impostor::testing {

absl::Status RunKernel(const gpu::VulkanContext& ctx, const uint32_t* spirv, size_t spirv_bytes,
                       const std::vector<KernelBinding>& bindings, const void* push, uint32_t push_size,
                       uint32_t groups_x, uint32_t groups_y) {
  VkDevice device = ctx.device();
  std::vector<VkDescriptorSetLayoutBinding> layout_bindings;
  for (uint32_t i = 0; i < bindings.size(); ++i) {
    layout_bindings.push_back({i, bindings[i].type, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr});
  }
  VkDescriptorSetLayoutCreateInfo set_info{};
  set_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
  set_info.bindingCount = static_cast<uint32_t>(layout_bindings.size());
  set_info.pBindings = layout_bindings.data();
  VkDescriptorSetLayout set_layout_raw;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateDescriptorSetLayout(device, &set_info, nullptr, &set_layout_raw));
  gpu::UniqueDescriptorSetLayout set_layout(device, set_layout_raw);

  VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, push_size};
  VkPipelineLayoutCreateInfo layout_info{};
  layout_info.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  layout_info.setLayoutCount = 1;
  layout_info.pSetLayouts = &set_layout_raw;
  layout_info.pushConstantRangeCount = 1;
  layout_info.pPushConstantRanges = &range;
  VkPipelineLayout pipeline_layout_raw;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreatePipelineLayout(device, &layout_info, nullptr, &pipeline_layout_raw));
  gpu::UniquePipelineLayout pipeline_layout(device, pipeline_layout_raw);

  VkShaderModuleCreateInfo module_info{};

  module_info.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
  module_info.codeSize = spirv_bytes;
  module_info.pCode = spirv;
  VkShaderModule module_raw;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateShaderModule(device, &module_info, nullptr, &module_raw));
  gpu::UniqueShaderModule module(device, module_raw);

  VkComputePipelineCreateInfo pipeline_info{};

  pipeline_info.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO;
  pipeline_info.stage = {};
  pipeline_info.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  pipeline_info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  pipeline_info.stage.module = module_raw;
  pipeline_info.stage.pName = "main";
  pipeline_info.layout = pipeline_layout_raw;
  VkPipeline pipeline_raw;
  IMPOSTOR_VK_RETURN_IF_ERROR(
      vkCreateComputePipelines(device, VK_NULL_HANDLE, 1, &pipeline_info, nullptr, &pipeline_raw));
  gpu::UniquePipeline pipeline(device, pipeline_raw);

  std::vector<VkDescriptorPoolSize> pool_sizes;
  for (const KernelBinding& b : bindings) pool_sizes.push_back({b.type, 1});
  VkDescriptorPoolCreateInfo pool_info{};
  pool_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
  pool_info.maxSets = 1;
  pool_info.poolSizeCount = static_cast<uint32_t>(pool_sizes.size());
  pool_info.pPoolSizes = pool_sizes.data();
  VkDescriptorPool pool_raw;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateDescriptorPool(device, &pool_info, nullptr, &pool_raw));
  gpu::UniqueDescriptorPool pool(device, pool_raw);
  VkDescriptorSetAllocateInfo alloc{};
  alloc.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
  alloc.descriptorPool = pool_raw;
  alloc.descriptorSetCount = 1;
  alloc.pSetLayouts = &set_layout_raw;
  VkDescriptorSet set;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkAllocateDescriptorSets(device, &alloc, &set));
  std::vector<VkDescriptorBufferInfo> buffer_infos(bindings.size());
  std::vector<VkDescriptorImageInfo> image_infos(bindings.size());
  std::vector<VkWriteDescriptorSet> writes(bindings.size());
  for (uint32_t i = 0; i < bindings.size(); ++i) {
    writes[i] = {};
    writes[i].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    writes[i].dstSet = set;
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = bindings[i].type;
    if (bindings[i].type == VK_DESCRIPTOR_TYPE_STORAGE_BUFFER) {
      buffer_infos[i] = {bindings[i].buffer, 0, VK_WHOLE_SIZE};
      writes[i].pBufferInfo = &buffer_infos[i];
    } else {
      image_infos[i] = {bindings[i].sampler, bindings[i].view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
      writes[i].pImageInfo = &image_infos[i];
    }
  }
  vkUpdateDescriptorSets(device, static_cast<uint32_t>(writes.size()), writes.data(), 0, nullptr);

  IMPOSTOR_GPU_ASSIGN_OR_RETURN(gpu::CommandRunner runner, gpu::CommandRunner::Create(ctx));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(VkCommandBuffer cmd, runner.Begin());
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_raw);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_layout_raw, 0, 1, &set, 0, nullptr);
  vkCmdPushConstants(cmd, pipeline_layout_raw, VK_SHADER_STAGE_COMPUTE_BIT, 0, push_size, push);
  vkCmdDispatch(cmd, groups_x, groups_y, 1);
  gpu::MemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
  return runner.SubmitAndWait();
}

absl::StatusOr<gpu::GpuImage> UploadImage(const gpu::VulkanContext& ctx, VkFormat format, uint32_t width,
                                          uint32_t height, const void* data, size_t bytes) {
  gpu::ImageSpec spec;
  spec.width = width;
  spec.height = height;
  spec.format = format;
  spec.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(gpu::GpuImage image, gpu::GpuImage::Create(ctx, spec, "runtime test image"));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(
      gpu::GpuBuffer staging,
      gpu::GpuBuffer::Create(ctx, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT, 0,
                             "runtime test staging"));
  std::memcpy(staging.mapped(), data, bytes);
  IMPOSTOR_GPU_RETURN_IF_ERROR(staging.FlushHostWrites());
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(gpu::CommandRunner runner, gpu::CommandRunner::Create(ctx));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(VkCommandBuffer cmd, runner.Begin());
  gpu::ImageTransition to_dst;
  to_dst.image = image.image();
  to_dst.old_layout = VK_IMAGE_LAYOUT_UNDEFINED;
  to_dst.new_layout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  to_dst.dst_stage = VK_PIPELINE_STAGE_2_COPY_BIT;
  to_dst.dst_access = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  gpu::TransitionImage(cmd, to_dst);
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.imageExtent = {width, height, 1};
  vkCmdCopyBufferToImage(cmd, staging.buffer(), image.image(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
  gpu::ImageTransition to_read;
  to_read.image = image.image();
  to_read.old_layout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  to_read.new_layout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
  to_read.src_stage = VK_PIPELINE_STAGE_2_COPY_BIT;
  to_read.src_access = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  to_read.dst_stage = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  to_read.dst_access = VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
  gpu::TransitionImage(cmd, to_read);
  IMPOSTOR_GPU_RETURN_IF_ERROR(runner.SubmitAndWait());
  return image;
}

}  // namespace impostor::testing
