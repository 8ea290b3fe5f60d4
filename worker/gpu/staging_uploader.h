// Copies host data into device-local buffers and textures through
// host-visible staging buffers. Copies are batched into one submission until
// about `batch_bytes` are staged (then submitted and waited on), which bounds
// the staging memory for texture-heavy scenes. Textures get a full mip chain
// generated on the GPU with linear vkCmdBlitImage, so atlas frames that show
// a texture minified (the usual case: a 4k texture in a 256 px tile) sample
// filtered levels instead of aliasing.
//
// Returned resources are usable only after Finish() returns OK. The uploader
// borrows `ctx` and `runner` (both must outlive it); not thread-safe.
#ifndef IMPOSTOR_WORKER_GPU_STAGING_UPLOADER_H_
#define IMPOSTOR_WORKER_GPU_STAGING_UPLOADER_H_

#include <vulkan/vulkan.h>

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "worker/gpu/command_runner.h"
#include "worker/gpu/gpu_buffer.h"
#include "worker/gpu/gpu_image.h"
#include "worker/gpu/vulkan_context.h"

namespace impostor::gpu {

// An RGBA8 texture with an sRGB view (colour: sampling decodes to linear) and
// a UNORM view (data: normals, metal-rough, occlusion) of the same texels,
// in SHADER_READ_ONLY_OPTIMAL layout once uploaded.
struct UploadedTexture {
  GpuImage image;
  VkImageView srgb_view = VK_NULL_HANDLE;   // owned by `image`
  VkImageView unorm_view = VK_NULL_HANDLE;  // owned by `image`
};

class StagingUploader {
 public:
  static constexpr VkDeviceSize kDefaultBatchBytes = VkDeviceSize{64} << 20;

  StagingUploader(const VulkanContext& ctx, CommandRunner& runner,
                  VkDeviceSize batch_bytes = kDefaultBatchBytes);

  // A device-local buffer with `usage` (TRANSFER_DST is added) holding
  // `size` bytes from `data`; ready for vertex/index reads after Finish().
  absl::StatusOr<GpuBuffer> UploadBuffer(const void* data, VkDeviceSize size,
                                         VkBufferUsageFlags usage, const std::string& name);

  // `rgba8` is width*height*4 bytes, rows top to bottom (row 0 = v 0). When
  // `srgb`, mip levels are filtered in linear light (the blit decodes sRGB).
  absl::StatusOr<UploadedTexture> UploadTexture(const uint8_t* rgba8, uint32_t width,
                                                uint32_t height, bool srgb,
                                                const std::string& name);

  // Submits what is pending and waits for it.
  absl::Status Finish();

  VkDeviceSize uploaded_bytes() const { return uploaded_bytes_; }

 private:
  // Returns a recording command buffer with room for `bytes` more staging,
  // flushing the current batch first when it is full.
  absl::StatusOr<VkCommandBuffer> Reserve(VkDeviceSize bytes);
  absl::StatusOr<GpuBuffer> Stage(const void* data, VkDeviceSize size, const std::string& name);

  const VulkanContext& ctx_;
  CommandRunner& runner_;
  VkDeviceSize batch_bytes_;
  VkDeviceSize pending_bytes_ = 0;
  VkDeviceSize uploaded_bytes_ = 0;
  std::vector<GpuBuffer> staging_;  // alive until their batch completes
};

}  // namespace impostor::gpu

#endif  // IMPOSTOR_WORKER_GPU_STAGING_UPLOADER_H_
