#include "worker/gpu/gpu_image.h"

#include "absl/strings/str_cat.h"
#include "worker/gpu/gpu_memory.h"
#include "worker/gpu/vk_check.h"

namespace impostor::gpu {

absl::StatusOr<GpuImage> GpuImage::Create(const VulkanContext& ctx, const ImageSpec& spec,
                                          const std::string& name) {
  const VkDevice device = ctx.device();
  GpuImage out;
  out.device_ = device;
  out.spec_ = spec;

  VkImageCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
  info.flags = spec.flags;
  info.imageType = VK_IMAGE_TYPE_2D;
  info.format = spec.format;
  info.extent = {spec.width, spec.height, 1};
  info.mipLevels = spec.mip_levels;
  info.arrayLayers = 1;
  info.samples = VK_SAMPLE_COUNT_1_BIT;
  info.tiling = VK_IMAGE_TILING_OPTIMAL;
  info.usage = spec.usage;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  VkImage image = VK_NULL_HANDLE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateImage(device, &info, nullptr, &image));
  out.image_ = UniqueImage(device, image);
  ctx.SetName(VK_OBJECT_TYPE_IMAGE, image, name);

  VkMemoryRequirements requirements{};
  vkGetImageMemoryRequirements(device, image, &requirements);
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(const uint32_t type,
                                FindMemoryType(ctx.memory_properties(), requirements.memoryTypeBits,
                                               VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT));
  IMPOSTOR_GPU_RETURN_IF_ERROR(CheckAllocationFits(
      ctx, name, requirements.size,
      absl::StrCat(spec.width, "x", spec.height, " image, ", spec.mip_levels, " mip levels")));
  VkMemoryAllocateInfo alloc{};
  alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
  alloc.allocationSize = requirements.size;
  alloc.memoryTypeIndex = type;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkAllocateMemory(device, &alloc, nullptr, &memory));
  out.memory_ = UniqueMemory(device, memory);
  IMPOSTOR_VK_RETURN_IF_ERROR(vkBindImageMemory(device, image, memory, 0));

  absl::StatusOr<VkImageView> view = out.AddView(spec.format);
  if (!view.ok()) return view.status();
  return out;
}

absl::StatusOr<VkImageView> GpuImage::AddView(VkFormat format) {
  VkImageViewCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO;
  info.image = image_.get();
  info.viewType = VK_IMAGE_VIEW_TYPE_2D;
  info.format = format;
  info.subresourceRange = {spec_.aspect, 0, spec_.mip_levels, 0, 1};
  VkImageView view = VK_NULL_HANDLE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateImageView(device_, &info, nullptr, &view));
  views_.emplace_back(device_, view);
  return view;
}

}  // namespace impostor::gpu
