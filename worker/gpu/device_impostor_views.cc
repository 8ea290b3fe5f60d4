#include "worker/gpu/device_impostor_views.h"

#include <algorithm>
#include <cstdint>

#include <glm/vec4.hpp>

#include "absl/strings/str_cat.h"
#include "common/atlas/frame_camera.h"
#include "common/util/parallel_for.h"
#include "shaders/impostor_runtime_view_comp.h"
#include "worker/gpu/barriers.h"
#include "worker/gpu/sampled_image_upload.h"
#include "worker/gpu/vk_check.h"

namespace impostor::gpu {
namespace {

constexpr int kGroupSize = 8;  // local_size_x/y of impostor_runtime_view.comp
// Per pixel: (linear albedo, alpha), (unit normal, view depth), (orm, 0).
constexpr VkDeviceSize kBytesPerPixel = 3 * sizeof(glm::vec4);

// impostor_runtime_view.comp's push constants.
struct ViewPush {
  glm::vec4 view_dir, view_up, view_right;
  glm::ivec4 params;     // layout, frames, tile size, blend mode
  glm::ivec4 flags;      // reconstruction (IMPOSTOR_RECONSTRUCT_*), has_orm, pixels, ring_views
  glm::ivec4 placement;  // x: the view's first pixel in the output buffer
};

// The shader's IMPOSTOR_RECONSTRUCT_* values.
int32_t ShaderReconstruction(const ReferenceRenderOptions& o) {
  if (o.reconstruction == Reconstruction::kDepth) return 2;
  return o.parallax ? 1 : 0;
}

}  // namespace

absl::StatusOr<std::unique_ptr<ImpostorViewKernel>> ImpostorViewKernel::Create(const VulkanContext& ctx) {
  std::unique_ptr<ImpostorViewKernel> out(new ImpostorViewKernel());
  // Nearest: the runtime filters texels itself (bilinear alpha, alpha-weighted
  // means), as the reference renderer does.
  VkSamplerCreateInfo sampler_info{};
  sampler_info.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO;
  sampler_info.magFilter = sampler_info.minFilter = VK_FILTER_NEAREST;
  sampler_info.addressModeU = sampler_info.addressModeV = sampler_info.addressModeW =
      VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  VkSampler sampler = VK_NULL_HANDLE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateSampler(ctx.device(), &sampler_info, nullptr, &sampler));
  out->sampler_ = UniqueSampler(ctx.device(), sampler);
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(
      out->pipeline_,
      ComputePipeline::Create(ctx, impostor_runtime_view_comp, sizeof(impostor_runtime_view_comp),
                              {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
                               VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
                              sizeof(ViewPush), "impostor runtime views"));
  return out;
}

absl::StatusOr<std::unique_ptr<DeviceImpostorViews>> DeviceImpostorViews::Create(const VulkanContext& ctx,
                                                                                 const ImpostorViewKernel& kernel,
                                                                                 const ImpostorAtlas& atlas) {
  if (!AtlasIsConsistent(atlas)) {
    return absl::InvalidArgumentError("impostor atlas: maps, cameras and layout do not agree");
  }
  std::unique_ptr<DeviceImpostorViews> out(new DeviceImpostorViews(ctx, kernel));
  out->layout_ = AtlasViewLayout(atlas);
  out->tile_size_ = TileSize(atlas.resolution, GridSide(out->layout_));
  out->has_orm_ = !atlas.orm.empty();
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(out->runner_, CommandRunner::Create(ctx));
  const auto w = static_cast<uint32_t>(atlas.width), h = static_cast<uint32_t>(atlas.height);
  // sRGB albedo: the shader reads linear colour, as a game samples it.
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(out->albedo_,
                                UploadSampledImage(ctx, out->runner_, VK_FORMAT_R8G8B8A8_SRGB, w, h,
                                                   atlas.albedo_alpha.data(), atlas.albedo_alpha.size(),
                                                   "impostor albedo_alpha"));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(out->normal_depth_,
                                UploadSampledImage(ctx, out->runner_, VK_FORMAT_R16G16B16A16_UNORM, w, h,
                                                   atlas.normal_depth.data(),
                                                   atlas.normal_depth.size() * sizeof(uint16_t),
                                                   "impostor normal_depth"));
  // Without an orm map the shader is told so (has_orm 0) and never reads
  // binding 2; it must still be a valid image, so albedo stands in.
  if (out->has_orm_) {
    IMPOSTOR_GPU_ASSIGN_OR_RETURN(out->orm_, UploadSampledImage(ctx, out->runner_, VK_FORMAT_R8G8B8A8_UNORM, w, h,
                                                                atlas.orm.data(), atlas.orm.size(), "impostor orm"));
  }
  return out;
}

absl::StatusOr<std::vector<ViewImages>> DeviceImpostorViews::RenderViews(const std::vector<FrameCamera>& cameras,
                                                                         int pixels,
                                                                         const ReferenceRenderOptions& options) {
  if (pixels <= 0) return absl::InvalidArgumentError(absl::StrCat("impostor views: pixels ", pixels, " <= 0"));
  const VkDeviceSize view_bytes = static_cast<VkDeviceSize>(pixels) * pixels * kBytesPerPixel;
  const size_t per_batch = static_cast<size_t>(std::max<VkDeviceSize>(1, kMaxViewBatchBytes / view_bytes));
  std::vector<ViewImages> out(cameras.size());
  for (size_t first = 0; first < cameras.size(); first += per_batch) {
    IMPOSTOR_GPU_RETURN_IF_ERROR(
        RenderBatch(cameras, first, std::min(per_batch, cameras.size() - first), pixels, options, &out));
  }
  return out;
}

absl::Status DeviceImpostorViews::RenderBatch(const std::vector<FrameCamera>& cameras, size_t first, size_t count,
                                              int pixels, const ReferenceRenderOptions& options,
                                              std::vector<ViewImages>* out) {
  const size_t view_pixels = static_cast<size_t>(pixels) * pixels;
  const VkDeviceSize bytes = count * view_pixels * kBytesPerPixel;
  if (pixels_.buffer() == VK_NULL_HANDLE || pixels_.size() < bytes) {
    pixels_ = GpuBuffer();
    IMPOSTOR_GPU_ASSIGN_OR_RETURN(pixels_, GpuBuffer::Create(ctx_, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                             VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT,
                                                             VK_MEMORY_PROPERTY_HOST_CACHED_BIT, "impostor views"));
  }
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(VkCommandBuffer cmd, runner_.Begin());
  const VkImageView orm = has_orm_ ? orm_.view() : albedo_.view();
  const ComputePipeline& pipeline = kernel_.pipeline();
  const VkSampler sampler = kernel_.sampler();
  pipeline.Bind(cmd, {{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, VK_NULL_HANDLE, albedo_.view(), sampler},
                      {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, VK_NULL_HANDLE, normal_depth_.view(), sampler},
                      {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, VK_NULL_HANDLE, orm, sampler},
                      {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, pixels_.buffer()}});
  const auto groups = static_cast<uint32_t>((pixels + kGroupSize - 1) / kGroupSize);
  for (size_t i = 0; i < count; ++i) {
    const FrameCamera& view = cameras[first + i];
    ViewPush push{};
    push.view_dir = glm::vec4(view.direction, 0.0f);
    push.view_up = glm::vec4(view.up, 0.0f);
    push.view_right = glm::vec4(view.right, 0.0f);
    push.params = {static_cast<int32_t>(layout_.kind), layout_.frames, tile_size_,
                   options.blend == BlendMode::kTriangle3 ? 0 : 1};
    push.flags = {ShaderReconstruction(options), has_orm_ ? 1 : 0, pixels, layout_.ring_views};
    push.placement = {static_cast<int32_t>(i * view_pixels), 0, 0, 0};
    pipeline.Push(cmd, &push);
    vkCmdDispatch(cmd, groups, groups, 1);
  }
  MemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_WRITE_BIT,
                VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
  IMPOSTOR_GPU_RETURN_IF_ERROR(runner_.SubmitAndWait());
  IMPOSTOR_GPU_RETURN_IF_ERROR(pixels_.InvalidateForHostRead());
  // Decoded on all cores, as the CPU path draws its views (a million pixels
  // per call at 256 px).
  const auto* px = static_cast<const glm::vec4*>(pixels_.mapped());
  ParallelFor(count, [&](size_t i) {
    ViewImages& v = (*out)[first + i];
    v = EmptyViewImages(pixels, has_orm_);
    const glm::vec4* view_px = px + i * view_pixels * 3;
    for (size_t p = 0; p < view_pixels; ++p) {
      const glm::vec4 a = view_px[p * 3], nd = view_px[p * 3 + 1], o = view_px[p * 3 + 2];
      if (a.w < 0.5f) continue;  // empty: the clear encodings, as RenderImpostorView
      const glm::vec3 orm(o);
      StoreShadedPixel(p, glm::vec3(a), glm::vec3(nd), nd.w, &orm, &v);
    }
  });
  return absl::OkStatus();
}

}  // namespace impostor::gpu
