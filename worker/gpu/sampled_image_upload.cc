#include "worker/gpu/sampled_image_upload.h"

#include <cstring>

#include "worker/gpu/barriers.h"
#include "worker/gpu/gpu_buffer.h"
#include "worker/gpu/vk_check.h"

namespace impostor::gpu {

absl::StatusOr<GpuImage> UploadSampledImage(const VulkanContext& ctx, CommandRunner& runner, VkFormat format,
                                            uint32_t width, uint32_t height, const void* data, size_t bytes,
                                            const std::string& name) {
  ImageSpec spec;
  spec.width = width;
  spec.height = height;
  spec.format = format;
  spec.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(GpuImage image, GpuImage::Create(ctx, spec, name));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(GpuBuffer staging,
                                GpuBuffer::Create(ctx, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                                  VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT, 0, name + " staging"));
  std::memcpy(staging.mapped(), data, bytes);
  IMPOSTOR_GPU_RETURN_IF_ERROR(staging.FlushHostWrites());
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(VkCommandBuffer cmd, runner.Begin());
  ImageTransition to_dst;
  to_dst.image = image.image();
  to_dst.old_layout = VK_IMAGE_LAYOUT_UNDEFINED;
  to_dst.new_layout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  to_dst.dst_stage = VK_PIPELINE_STAGE_2_COPY_BIT;
  to_dst.dst_access = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  TransitionImage(cmd, to_dst);
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.imageExtent = {width, height, 1};
  vkCmdCopyBufferToImage(cmd, staging.buffer(), image.image(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
  ImageTransition to_read;
  to_read.image = image.image();
  to_read.old_layout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  to_read.new_layout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
  to_read.src_stage = VK_PIPELINE_STAGE_2_COPY_BIT;
  to_read.src_access = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  to_read.dst_stage = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  to_read.dst_access = VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
  TransitionImage(cmd, to_read);
  IMPOSTOR_GPU_RETURN_IF_ERROR(runner.SubmitAndWait());
  return image;
}

}  // namespace impostor::gpu
