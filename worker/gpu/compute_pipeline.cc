#include "worker/gpu/compute_pipeline.h"

#include "worker/gpu/vk_check.h"

namespace impostor::gpu {

absl::StatusOr<ComputePipeline> ComputePipeline::Create(const VulkanContext& ctx, const uint32_t* spirv,
                                                        size_t spirv_bytes,
                                                        const std::vector<VkDescriptorType>& bindings,
                                                        uint32_t push_size, const char* name) {
  ComputePipeline out;
  VkDevice device = ctx.device();
  out.device_ = device;
  out.push_size_ = push_size;

  std::vector<VkDescriptorSetLayoutBinding> layout_bindings;
  for (uint32_t i = 0; i < bindings.size(); ++i) {
    layout_bindings.push_back({i, bindings[i], 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr});
  }
  VkDescriptorSetLayoutCreateInfo set_info{};
  set_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
  set_info.bindingCount = static_cast<uint32_t>(layout_bindings.size());
  set_info.pBindings = layout_bindings.data();
  VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateDescriptorSetLayout(device, &set_info, nullptr, &set_layout));
  out.set_layout_ = UniqueDescriptorSetLayout(device, set_layout);

  const VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, push_size};
  VkPipelineLayoutCreateInfo layout_info{};
  layout_info.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  layout_info.setLayoutCount = 1;
  layout_info.pSetLayouts = &set_layout;
  layout_info.pushConstantRangeCount = push_size > 0 ? 1 : 0;
  layout_info.pPushConstantRanges = &range;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreatePipelineLayout(device, &layout_info, nullptr, &layout));
  out.layout_ = UniquePipelineLayout(device, layout);

  VkShaderModuleCreateInfo module_info{};
  module_info.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
  module_info.codeSize = spirv_bytes;
  module_info.pCode = spirv;
  VkShaderModule module = VK_NULL_HANDLE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateShaderModule(device, &module_info, nullptr, &module));
  const UniqueShaderModule shader(device, module);

  VkComputePipelineCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO;
  info.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  info.stage.module = module;
  info.stage.pName = "main";
  info.layout = layout;
  VkPipeline pipeline = VK_NULL_HANDLE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateComputePipelines(device, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline));
  out.pipeline_ = UniquePipeline(device, pipeline);
  ctx.SetName(VK_OBJECT_TYPE_PIPELINE, reinterpret_cast<uint64_t>(pipeline), name);

  std::vector<VkDescriptorPoolSize> pool_sizes;
  for (VkDescriptorType type : bindings) pool_sizes.push_back({type, 1});
  VkDescriptorPoolCreateInfo pool_info{};
  pool_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
  pool_info.maxSets = 1;
  pool_info.poolSizeCount = static_cast<uint32_t>(pool_sizes.size());
  pool_info.pPoolSizes = pool_sizes.data();
  VkDescriptorPool pool = VK_NULL_HANDLE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateDescriptorPool(device, &pool_info, nullptr, &pool));
  out.pool_ = UniqueDescriptorPool(device, pool);
  VkDescriptorSetAllocateInfo alloc{};
  alloc.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
  alloc.descriptorPool = pool;
  alloc.descriptorSetCount = 1;
  alloc.pSetLayouts = &set_layout;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkAllocateDescriptorSets(device, &alloc, &out.set_));
  return out;
}

void ComputePipeline::Bind(VkCommandBuffer cmd, const std::vector<ComputeBinding>& bindings) const {
  std::vector<VkDescriptorBufferInfo> buffer_infos(bindings.size());
  std::vector<VkDescriptorImageInfo> image_infos(bindings.size());
  std::vector<VkWriteDescriptorSet> writes(bindings.size());
  for (uint32_t i = 0; i < bindings.size(); ++i) {
    writes[i] = {};
    writes[i].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    writes[i].dstSet = set_;
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
  vkUpdateDescriptorSets(device_, static_cast<uint32_t>(writes.size()), writes.data(), 0, nullptr);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_.get());
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_.get(), 0, 1, &set_, 0, nullptr);
}

void ComputePipeline::Push(VkCommandBuffer cmd, const void* data) const {
  vkCmdPushConstants(cmd, layout_.get(), VK_SHADER_STAGE_COMPUTE_BIT, 0, push_size_, data);
}

}  // namespace impostor::gpu
