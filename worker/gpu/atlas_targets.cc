#include "worker/gpu/atlas_targets.h"

#include <array>
#include <cstring>

#include "absl/strings/str_cat.h"

#include "worker/gpu/barriers.h"
#include "worker/gpu/device_selection.h"
#include "worker/gpu/vk_check.h"

namespace impostor::gpu {
namespace {

constexpr VkPipelineStageFlags2 kColorStage = VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT;
constexpr VkAccessFlags2 kColorAccess =
    VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT;
constexpr VkPipelineStageFlags2 kDepthStage =
    VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
constexpr VkAccessFlags2 kDepthAccess =
    VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;

absl::StatusOr<GpuImage> CreateTarget(const VulkanContext& ctx, uint32_t size, VkFormat format,
                                      VkImageUsageFlags usage, VkImageAspectFlags aspect,
                                      const char* name, VkImageCreateFlags flags = 0) {
  ImageSpec spec;
  spec.flags = flags;
  spec.width = size;
  spec.height = size;
  spec.format = format;
  spec.usage = usage;
  spec.aspect = aspect;
  return GpuImage::Create(ctx, spec, name);
}

absl::StatusOr<GpuBuffer> CreateReadback(const VulkanContext& ctx, VkDeviceSize bytes,
                                         const char* name, bool resolved) {
  // HOST_CACHED makes the CPU's read of a multi-megabyte map fast; uncached
  // write-combined memory is read at a fraction of the speed. A resolved
  // bake's compute shader writes the buffers directly.
  return GpuBuffer::Create(ctx, bytes,
                           resolved ? VK_BUFFER_USAGE_STORAGE_BUFFER_BIT : VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                           VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT, VK_MEMORY_PROPERTY_HOST_CACHED_BIT,
                           name);
}

}  // namespace

absl::StatusOr<AtlasTargets> AtlasTargets::Create(const VulkanContext& ctx, uint32_t size,
                                                  bool emissive, uint32_t resolve_factor) {
  if (resolve_factor < 1 || size % resolve_factor != 0) {
    return absl::InvalidArgumentError(absl::StrCat("supersampling: a ", size, "x", size,
                                                   " atlas cannot be resolved by a factor of ", resolve_factor));
  }
  AtlasTargets t;
  t.size_ = size;
  t.resolve_factor_ = resolve_factor;
  t.out_size_ = size / resolve_factor;
  t.has_emissive_ = emissive;
  const bool resolved = resolve_factor > 1;
  VkImageUsageFlags color_usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  if (resolved) color_usage |= VK_IMAGE_USAGE_SAMPLED_BIT;
  // The sRGB targets get a UNORM view for the resolve, which needs
  // MUTABLE_FORMAT.
  const VkImageCreateFlags srgb_flags =
      resolved ? VkImageCreateFlags{VK_IMAGE_CREATE_MUTABLE_FORMAT_BIT} : VkImageCreateFlags{0};
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(t.albedo_, CreateTarget(ctx, size, kAlbedoFormat, color_usage,
                                                        VK_IMAGE_ASPECT_COLOR_BIT, "atlas albedo", srgb_flags));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(t.normal_depth_,
                                CreateTarget(ctx, size, kNormalDepthFormat, color_usage,
                                             VK_IMAGE_ASPECT_COLOR_BIT, "atlas normal_depth"));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(t.orm_, CreateTarget(ctx, size, kOrmFormat, color_usage,
                                                     VK_IMAGE_ASPECT_COLOR_BIT, "atlas orm"));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(
      t.depth_, CreateTarget(ctx, size, kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                             VK_IMAGE_ASPECT_DEPTH_BIT, "atlas depth"));
  const VkDeviceSize texels = VkDeviceSize{t.out_size_} * t.out_size_;
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(t.albedo_readback_,
                                CreateReadback(ctx, texels * 4, "albedo readback", resolved));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(t.normal_depth_readback_,
                                CreateReadback(ctx, texels * 8, "normal_depth readback", resolved));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(t.orm_readback_, CreateReadback(ctx, texels * 4, "orm readback", resolved));
  if (emissive) {
    IMPOSTOR_GPU_ASSIGN_OR_RETURN(
        t.emissive_, CreateTarget(ctx, size, kEmissiveFormat, color_usage,
                                  VK_IMAGE_ASPECT_COLOR_BIT, "atlas emissive", srgb_flags));
    IMPOSTOR_GPU_ASSIGN_OR_RETURN(t.emissive_readback_,
                                  CreateReadback(ctx, texels * 4, "emissive readback", resolved));
  }
  if (resolved) {
    IMPOSTOR_GPU_ASSIGN_OR_RETURN(t.albedo_unorm_, t.albedo_.AddView(VK_FORMAT_R8G8B8A8_UNORM));
    if (emissive) {
      IMPOSTOR_GPU_ASSIGN_OR_RETURN(t.emissive_unorm_, t.emissive_.AddView(VK_FORMAT_R8G8B8A8_UNORM));
    }
  }
  return t;
}

void AtlasTargets::BeginRendering(VkCommandBuffer cmd, bool first_use) const {
  if (first_use) {
    std::array<ImageTransition, 5> init{};
    const std::array<VkImage, 3> colors = {albedo_.image(), normal_depth_.image(), orm_.image()};
    for (size_t i = 0; i < colors.size(); ++i) {
      init[i].image = colors[i];
      init[i].old_layout = VK_IMAGE_LAYOUT_UNDEFINED;
      init[i].new_layout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
      init[i].dst_stage = kColorStage;
      init[i].dst_access = kColorAccess;
    }
    init[3].image = depth_.image();
    init[3].aspect = VK_IMAGE_ASPECT_DEPTH_BIT;
    init[3].old_layout = VK_IMAGE_LAYOUT_UNDEFINED;
    init[3].new_layout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    init[3].dst_stage = kDepthStage;
    init[3].dst_access = kDepthAccess;
    uint32_t count = 4;
    if (has_emissive_) {
      init[4] = init[0];
      init[4].image = emissive_.image();
      count = 5;
    }
    TransitionImages(cmd, init.data(), count);
  } else {
    // The previous chunk was a separate submission; its attachment writes
    // must be complete and visible before this chunk loads them.
    MemoryBarrier(
        cmd, kColorStage | kDepthStage,
        VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
        kColorStage | kDepthStage, kColorAccess | kDepthAccess);
  }

  const VkAttachmentLoadOp load =
      first_use ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD;
  // Clear values are the "empty texel" encodings of atlas_renderer.h.
  // The pipeline always has four colour attachments; without an emissive
  // target the fourth is VK_NULL_HANDLE and its writes are discarded.
  std::array<VkRenderingAttachmentInfo, 4> colors{};
  const std::array<VkImageView, 4> views = {albedo_.view(), normal_depth_.view(), orm_.view(),
                                            has_emissive_ ? emissive_.view() : VK_NULL_HANDLE};
  const std::array<VkClearColorValue, 4> clears = {{
      {{0.0f, 0.0f, 0.0f, 0.0f}},
      {{0.5f, 0.5f, 0.5f, 1.0f}},
      {{0.0f, 0.0f, 0.0f, 0.0f}},
      {{0.0f, 0.0f, 0.0f, 0.0f}},
  }};
  for (size_t i = 0; i < colors.size(); ++i) {
    colors[i].sType = VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO;
    colors[i].imageView = views[i];
    colors[i].imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    colors[i].loadOp = load;
    colors[i].storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    colors[i].clearValue.color = clears[i];
  }
  VkRenderingAttachmentInfo depth{};
  depth.sType = VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO;
  depth.imageView = depth_.view();
  depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  depth.loadOp = load;
  // Later chunks never touch earlier tiles, but they do load the image.
  depth.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  depth.clearValue.depthStencil = {1.0f, 0};

  VkRenderingInfo info{};
  info.sType = VK_STRUCTURE_TYPE_RENDERING_INFO;
  info.renderArea = {{0, 0}, {size_, size_}};
  info.layerCount = 1;
  info.colorAttachmentCount = static_cast<uint32_t>(colors.size());
  info.pColorAttachments = colors.data();
  info.pDepthAttachment = &depth;
  vkCmdBeginRendering(cmd, &info);
}

void AtlasTargets::RecordResolve(VkCommandBuffer cmd, const SupersampleResolve& resolve) const {
  const std::array<const GpuImage*, 4> images = {&albedo_, &normal_depth_, &orm_, &emissive_};
  const size_t count = has_emissive_ ? 4 : 3;
  std::array<ImageTransition, 4> to_read{};
  for (size_t i = 0; i < count; ++i) {
    to_read[i].image = images[i]->image();
    to_read[i].old_layout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    to_read[i].new_layout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
    to_read[i].src_stage = kColorStage;
    to_read[i].src_access = VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT;
    to_read[i].dst_stage = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
    to_read[i].dst_access = VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
  }
  TransitionImages(cmd, to_read.data(), static_cast<uint32_t>(count));
  // Without emissive, its bindings get the albedo view and buffer as
  // placeholders the shader never touches.
  resolve.Record(cmd, {.albedo_view = albedo_unorm_,
                       .normal_depth_view = normal_depth_.view(),
                       .orm_view = orm_.view(),
                       .emissive_view = has_emissive_ ? emissive_unorm_ : albedo_unorm_,
                       .albedo_buffer = albedo_readback_.buffer(),
                       .normal_depth_buffer = normal_depth_readback_.buffer(),
                       .orm_buffer = orm_readback_.buffer(),
                       .emissive_buffer = has_emissive_ ? emissive_readback_.buffer() : albedo_readback_.buffer(),
                       .factor = resolve_factor_,
                       .out_width = out_size_,
                       .out_height = out_size_,
                       .emissive = has_emissive_});
  MemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
}

void AtlasTargets::RecordReadback(VkCommandBuffer cmd, const SupersampleResolve* resolve) const {
  if (resolve_factor_ > 1) {
    RecordResolve(cmd, *resolve);
    return;
  }
  const std::array<const GpuImage*, 4> images = {&albedo_, &normal_depth_, &orm_, &emissive_};
  const std::array<const GpuBuffer*, 4> buffers = {&albedo_readback_, &normal_depth_readback_,
                                                   &orm_readback_, &emissive_readback_};
  const size_t count = has_emissive_ ? 4 : 3;
  std::array<ImageTransition, 4> to_src{};
  for (size_t i = 0; i < count; ++i) {
    to_src[i].image = images[i]->image();
    to_src[i].old_layout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    to_src[i].new_layout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    to_src[i].src_stage = kColorStage;
    to_src[i].src_access = VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT;
    to_src[i].dst_stage = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
    to_src[i].dst_access = VK_ACCESS_2_TRANSFER_READ_BIT;
  }
  TransitionImages(cmd, to_src.data(), static_cast<uint32_t>(count));
  for (size_t i = 0; i < count; ++i) {
    // bufferRowLength 0 = tightly packed; image row 0 (clip y = -1, the
    // camera's up side) lands first, as AtlasImages wants.
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {size_, size_, 1};
    vkCmdCopyImageToBuffer(cmd, images[i]->image(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                           buffers[i]->buffer(), 1, &region);
  }
  MemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
}

absl::Status AtlasTargets::CopyToHost(AtlasImages* out) const {
  const size_t texels = static_cast<size_t>(out_size_) * out_size_;
  out->width = static_cast<int>(out_size_);
  out->height = static_cast<int>(out_size_);
  IMPOSTOR_GPU_RETURN_IF_ERROR(albedo_readback_.InvalidateForHostRead());
  IMPOSTOR_GPU_RETURN_IF_ERROR(normal_depth_readback_.InvalidateForHostRead());
  IMPOSTOR_GPU_RETURN_IF_ERROR(orm_readback_.InvalidateForHostRead());
  out->albedo_alpha.resize(texels * 4);
  out->normal_depth.resize(texels * 4);
  out->orm.resize(texels * 4);
  std::memcpy(out->albedo_alpha.data(), albedo_readback_.mapped(), texels * 4);
  std::memcpy(out->normal_depth.data(), normal_depth_readback_.mapped(), texels * 8);
  std::memcpy(out->orm.data(), orm_readback_.mapped(), texels * 4);
  out->emissive.clear();
  if (has_emissive_) {
    IMPOSTOR_GPU_RETURN_IF_ERROR(emissive_readback_.InvalidateForHostRead());
    out->emissive.resize(texels * 4);
    std::memcpy(out->emissive.data(), emissive_readback_.mapped(), texels * 4);
  }
  return absl::OkStatus();
}

}  // namespace impostor::gpu
