// A 2D VkImage with its own device-local memory and any number of views.
// Move-only; destruction order is views, image, memory, and the owner must
// know the GPU is done with it (fence waited).
// Thread-safety: none.
#ifndef IMPOSTOR_WORKER_GPU_GPU_IMAGE_H_
#define IMPOSTOR_WORKER_GPU_GPU_IMAGE_H_

#include <vulkan/vulkan.h>

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "worker/gpu/vk_handle.h"
#include "worker/gpu/vulkan_context.h"

namespace impostor::gpu {

struct ImageSpec {
  uint32_t width = 0;
  uint32_t height = 0;
  uint32_t mip_levels = 1;
  VkFormat format = VK_FORMAT_UNDEFINED;
  VkImageUsageFlags usage = 0;
  VkImageCreateFlags flags = 0;  // e.g. MUTABLE_FORMAT for sRGB + UNORM views
  VkImageAspectFlags aspect = VK_IMAGE_ASPECT_COLOR_BIT;
};

class GpuImage {
 public:
  // Creates the image, binds device-local memory and makes one view in
  // spec.format covering every mip level.
  static absl::StatusOr<GpuImage> Create(const VulkanContext& ctx, const ImageSpec& spec,
                                         const std::string& name);

  GpuImage() = default;
  GpuImage(GpuImage&&) noexcept = default;
  GpuImage& operator=(GpuImage&&) noexcept = default;

  // Another view of every mip level in a compatible format (the image needs
  // VK_IMAGE_CREATE_MUTABLE_FORMAT_BIT). Owned by this image.
  absl::StatusOr<VkImageView> AddView(VkFormat format);

  VkImage image() const { return image_.get(); }
  VkImageView view() const { return views_.empty() ? VK_NULL_HANDLE : views_.front().get(); }
  const ImageSpec& spec() const { return spec_; }

 private:
  VkDevice device_ = VK_NULL_HANDLE;
  ImageSpec spec_;
  // Declaration order = reverse destruction order.
  UniqueMemory memory_;
  UniqueImage image_;
  std::vector<UniqueImageView> views_;
};

}  // namespace impostor::gpu

#endif  // IMPOSTOR_WORKER_GPU_GPU_IMAGE_H_
