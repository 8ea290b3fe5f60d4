#include "worker/gpu/staging_uploader.h"

#include <algorithm>
#include <cstring>
#include <utility>

#include "worker/gpu/barriers.h"
#include "worker/gpu/vk_check.h"

namespace impostor::gpu {
namespace {

uint32_t FullMipCount(uint32_t width, uint32_t height) {
  uint32_t levels = 1;
  for (uint32_t size = std::max(width, height); size > 1; size >>= 1) ++levels;
  return levels;
}

bool CanBlitLinear(VkPhysicalDevice device, VkFormat format) {
  VkFormatProperties props{};
  vkGetPhysicalDeviceFormatProperties(device, format, &props);
  constexpr VkFormatFeatureFlags kNeeded = VK_FORMAT_FEATURE_BLIT_SRC_BIT |
                                           VK_FORMAT_FEATURE_BLIT_DST_BIT |
                                           VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT;
  return (props.optimalTilingFeatures & kNeeded) == kNeeded;
}

}  // namespace

StagingUploader::StagingUploader(const VulkanContext& ctx, CommandRunner& runner,
                                 VkDeviceSize batch_bytes)
    : ctx_(ctx), runner_(runner), batch_bytes_(batch_bytes) {}

absl::StatusOr<VkCommandBuffer> StagingUploader::Reserve(VkDeviceSize bytes) {
  if (runner_.recording() && pending_bytes_ > 0 && pending_bytes_ + bytes > batch_bytes_) {
    IMPOSTOR_GPU_RETURN_IF_ERROR(Finish());
  }
  if (!runner_.recording()) {
    absl::StatusOr<VkCommandBuffer> cmd = runner_.Begin();
    if (!cmd.ok()) return cmd.status();
  }
  pending_bytes_ += bytes;
  uploaded_bytes_ += bytes;
  return runner_.buffer();
}

absl::StatusOr<GpuBuffer> StagingUploader::Stage(const void* data, VkDeviceSize size,
                                                 const std::string& name) {
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(
      GpuBuffer staging,
      GpuBuffer::Create(ctx_, size, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                        VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT, 0, name + " staging"));
  std::memcpy(staging.mapped(), data, size);
  IMPOSTOR_GPU_RETURN_IF_ERROR(staging.FlushHostWrites());
  return staging;
}

absl::StatusOr<GpuBuffer> StagingUploader::UploadBuffer(const void* data, VkDeviceSize size,
                                                        VkBufferUsageFlags usage,
                                                        const std::string& name) {
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(VkCommandBuffer cmd, Reserve(size));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(GpuBuffer staging, Stage(data, size, name));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(
      GpuBuffer buffer, GpuBuffer::Create(ctx_, size, usage | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                          VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, 0, name));
  const VkBufferCopy region{0, 0, size};
  vkCmdCopyBuffer(cmd, staging.buffer(), buffer.buffer(), 1, &region);
  staging_.push_back(std::move(staging));
  return buffer;
}

absl::StatusOr<UploadedTexture> StagingUploader::UploadTexture(const uint8_t* rgba8, uint32_t width,
                                                               uint32_t height, bool srgb,
                                                               const std::string& name) {
  const VkDeviceSize size = VkDeviceSize{width} * height * 4;
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(VkCommandBuffer cmd, Reserve(size));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(GpuBuffer staging, Stage(rgba8, size, name));

  const VkFormat format = srgb ? VK_FORMAT_R8G8B8A8_SRGB : VK_FORMAT_R8G8B8A8_UNORM;
  const uint32_t mips =
      CanBlitLinear(ctx_.physical_device(), format) ? FullMipCount(width, height) : 1;
  ImageSpec spec;
  spec.width = width;
  spec.height = height;
  spec.mip_levels = mips;
  spec.format = format;
  spec.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT |
               VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  // Both formats view the same texels: a texture the glTF marks as colour
  // can still be bound as data by a (malformed) material, and vice versa.
  spec.flags = VK_IMAGE_CREATE_MUTABLE_FORMAT_BIT;
  UploadedTexture out;
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(out.image, GpuImage::Create(ctx_, spec, name));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(
      VkImageView other_view,
      out.image.AddView(srgb ? VK_FORMAT_R8G8B8A8_UNORM : VK_FORMAT_R8G8B8A8_SRGB));
  out.srgb_view = srgb ? out.image.view() : other_view;
  out.unorm_view = srgb ? other_view : out.image.view();
  const VkImage image = out.image.image();

  ImageTransition to_dst;
  to_dst.image = image;
  to_dst.mip_count = mips;
  to_dst.old_layout = VK_IMAGE_LAYOUT_UNDEFINED;
  to_dst.new_layout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  to_dst.dst_stage = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
  to_dst.dst_access = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  TransitionImage(cmd, to_dst);

  VkBufferImageCopy copy{};
  copy.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  copy.imageExtent = {width, height, 1};
  vkCmdCopyBufferToImage(cmd, staging.buffer(), image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1,
                         &copy);

  // Each level is a linear 2x box-ish downsample of the one above it.
  int32_t w = static_cast<int32_t>(width);
  int32_t h = static_cast<int32_t>(height);
  for (uint32_t level = 1; level < mips; ++level) {
    ImageTransition to_src;
    to_src.image = image;
    to_src.base_mip = level - 1;
    to_src.old_layout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    to_src.new_layout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    to_src.src_stage = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
    to_src.src_access = VK_ACCESS_2_TRANSFER_WRITE_BIT;
    to_src.dst_stage = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
    to_src.dst_access = VK_ACCESS_2_TRANSFER_READ_BIT;
    TransitionImage(cmd, to_src);

    const int32_t next_w = std::max(1, w / 2);
    const int32_t next_h = std::max(1, h / 2);
    VkImageBlit blit{};
    blit.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level - 1, 0, 1};
    blit.srcOffsets[1] = {w, h, 1};
    blit.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level, 0, 1};
    blit.dstOffsets[1] = {next_w, next_h, 1};
    vkCmdBlitImage(cmd, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, image,
                   VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &blit, VK_FILTER_LINEAR);
    w = next_w;
    h = next_h;
  }

  // Levels above the last were blit sources; the last was only written.
  ImageTransition to_read[2];
  uint32_t count = 0;
  if (mips > 1) {
    ImageTransition& t = to_read[count++];
    t.image = image;
    t.base_mip = 0;
    t.mip_count = mips - 1;
    t.old_layout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    t.new_layout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
    t.src_stage = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
    t.src_access = VK_ACCESS_2_TRANSFER_READ_BIT;
    t.dst_stage = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
    t.dst_access = VK_ACCESS_2_SHADER_READ_BIT;
  }
  ImageTransition& last = to_read[count++];
  last.image = image;
  last.base_mip = mips - 1;
  last.old_layout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  last.new_layout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
  last.src_stage = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
  last.src_access = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  last.dst_stage = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
  last.dst_access = VK_ACCESS_2_SHADER_READ_BIT;
  TransitionImages(cmd, to_read, count);

  staging_.push_back(std::move(staging));
  return out;
}

absl::Status StagingUploader::Finish() {
  if (!runner_.recording()) return absl::OkStatus();
  // Buffer copies must land before the vertex/index fetches of later
  // submissions (images were handed over by their own barriers above).
  MemoryBarrier(runner_.buffer(), VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_VERTEX_INPUT_BIT,
                VK_ACCESS_2_VERTEX_ATTRIBUTE_READ_BIT | VK_ACCESS_2_INDEX_READ_BIT);
  const absl::Status status = runner_.SubmitAndWait();
  // The batch is done (or the device is lost): staging memory can go.
  staging_.clear();
  pending_bytes_ = 0;
  return status;
}

}  // namespace impostor::gpu
