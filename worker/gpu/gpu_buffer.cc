#include "worker/gpu/gpu_buffer.h"

#include "worker/gpu/gpu_memory.h"
#include "worker/gpu/vk_check.h"

namespace impostor::gpu {

absl::StatusOr<GpuBuffer> GpuBuffer::Create(const VulkanContext& ctx, VkDeviceSize size,
                                            VkBufferUsageFlags usage,
                                            VkMemoryPropertyFlags required,
                                            VkMemoryPropertyFlags preferred,
                                            const std::string& name) {
  // Before vkCreateBuffer: a driver need not refuse an oversized buffer or
  // allocation (lavapipe crashed writing past 2 GiB).
  IMPOSTOR_GPU_RETURN_IF_ERROR(CheckBufferFits(ctx, name, size, usage));
  const VkDevice device = ctx.device();
  GpuBuffer out;
  out.device_ = device;
  out.size_ = size;

  VkBufferCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  info.size = size;
  info.usage = usage;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  VkBuffer buffer = VK_NULL_HANDLE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateBuffer(device, &info, nullptr, &buffer));
  out.buffer_ = UniqueBuffer(device, buffer);
  ctx.SetName(VK_OBJECT_TYPE_BUFFER, buffer, name);

  VkMemoryRequirements requirements{};
  vkGetBufferMemoryRequirements(device, buffer, &requirements);
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(
      const uint32_t type,
      FindMemoryType(ctx.memory_properties(), requirements.memoryTypeBits, required, preferred));
  IMPOSTOR_GPU_RETURN_IF_ERROR(CheckAllocationFits(ctx, name, requirements.size));
  VkMemoryAllocateInfo alloc{};
  alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
  alloc.allocationSize = requirements.size;
  alloc.memoryTypeIndex = type;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkAllocateMemory(device, &alloc, nullptr, &memory));
  out.memory_ = UniqueMemory(device, memory);
  IMPOSTOR_VK_RETURN_IF_ERROR(vkBindBufferMemory(device, buffer, memory, 0));

  const VkMemoryPropertyFlags flags = ctx.memory_properties().memoryTypes[type].propertyFlags;
  if (flags & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT) {
    out.coherent_ = (flags & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT) != 0;
    IMPOSTOR_VK_RETURN_IF_ERROR(vkMapMemory(device, memory, 0, VK_WHOLE_SIZE, 0, &out.mapped_));
  }
  return out;
}

absl::Status GpuBuffer::FlushHostWrites() const {
  if (coherent_ || mapped_ == nullptr) return absl::OkStatus();
  VkMappedMemoryRange range{};
  range.sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE;
  range.memory = memory_.get();
  range.size = VK_WHOLE_SIZE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkFlushMappedMemoryRanges(device_, 1, &range));
  return absl::OkStatus();
}

absl::Status GpuBuffer::InvalidateForHostRead() const {
  if (coherent_ || mapped_ == nullptr) return absl::OkStatus();
  VkMappedMemoryRange range{};
  range.sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE;
  range.memory = memory_.get();
  range.size = VK_WHOLE_SIZE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkInvalidateMappedMemoryRanges(device_, 1, &range));
  return absl::OkStatus();
}

}  // namespace impostor::gpu
