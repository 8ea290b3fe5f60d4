// AtlasRenderer on Vulkan 1.3: one pipeline for the renderer's life; per
// Render() a fresh upload of the scene (unless KeepSceneUploaded kept it)
// and fresh atlas targets, frames
// recorded in chunks (one submission + fence wait each, so progress can be
// reported and no single submission runs long enough to trip a GPU watchdog),
// then one readback submission.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "worker/gpu/atlas_renderer.h"
#include "worker/gpu/atlas_targets.h"
#include "worker/gpu/bake_pipeline.h"
#include "worker/gpu/command_runner.h"
#include "worker/gpu/device_impostor_views.h"
#include "worker/gpu/render_validation.h"
#include "worker/gpu/scene_resources.h"
#include "worker/gpu/supersample_resolve.h"
#include "worker/gpu/texture_filter.h"
#include "worker/gpu/vk_check.h"
#include "worker/gpu/vulkan_context.h"

namespace impostor {
namespace {

using gpu::AtlasTargets;
using gpu::BakePipeline;
using gpu::CommandRunner;
using gpu::MaterialPushConstants;
using gpu::SceneResources;
using gpu::SupersampleResolve;
using gpu::VulkanContext;

// Frames per submission: at most 16, fewer for heavy scenes so one
// submission stays around a few million triangles.
constexpr int kMaxFramesPerChunk = 16;
constexpr size_t kTrianglesPerChunk = size_t{4} << 20;

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Waits for the device before the Render() locals it guards are destroyed,
// so no error path can free a resource a submission still reads. Declared
// after those locals (destructors run in reverse order); costs nothing when
// the queue is already idle.
class IdleBeforeRelease {
 public:
  explicit IdleBeforeRelease(VkDevice device) : device_(device) {}
  ~IdleBeforeRelease() { vkDeviceWaitIdle(device_); }
  IdleBeforeRelease(const IdleBeforeRelease&) = delete;
  IdleBeforeRelease& operator=(const IdleBeforeRelease&) = delete;

 private:
  VkDevice device_;
};

// Per-batch draw state, computed once per Render().
struct BatchDraw {
  uint32_t first_index;
  uint32_t index_count;
  int material;
  VkCullModeFlags cull;
  VkFrontFace front_face;
};

// Ownership: owns the context (declared first, so destroyed last), the
// pipeline and the command runner. Thread-safety: one thread at a time, as
// AtlasRenderer documents.
class AtlasRendererVulkan final : public AtlasRenderer {
 public:
  AtlasRendererVulkan(std::unique_ptr<VulkanContext> ctx, BakePipeline pipeline,
                      SupersampleResolve resolve, CommandRunner runner)
      : ctx_(std::move(ctx)),
        pipeline_(std::move(pipeline)),
        resolve_(std::move(resolve)),
        runner_(std::move(runner)) {}

  const DeviceInfo& device() const override { return ctx_->info(); }

  absl::StatusOr<AtlasImages> Render(const Scene& scene, const BoundingSphere& sphere,
                                     const std::vector<FrameCamera>& cameras, int atlas_size,
                                     const std::function<void(double)>& progress,
                                     RenderTimings* timings) override;

  void KeepSceneUploaded(const Scene* scene) override {
    kept_scene_ = scene;
    // Render returns with the device idle, so no submission still reads it.
    kept_resources_.reset();
  }

  absl::StatusOr<std::unique_ptr<DeviceImpostor>> UploadImpostor(const ImpostorAtlas& atlas) override {
    if (!view_kernel_) {
      IMPOSTOR_GPU_ASSIGN_OR_RETURN(view_kernel_, gpu::ImpostorViewKernel::Create(*ctx_));
    }
    return gpu::DeviceImpostorViews::Create(*ctx_, *view_kernel_, atlas);
  }

 private:
  // The scene's resources for this Render, filtering as `filter` says: the
  // kept upload when it is of `scene`, else a fresh one (kept when `scene`
  // is the kept scene, else owned by `fresh` for the call).
  absl::StatusOr<const SceneResources*> ResourcesFor(const Scene& scene, const gpu::TextureFilter& filter,
                                                     std::unique_ptr<SceneResources>* fresh);

  void RecordFrame(VkCommandBuffer cmd, const FrameCamera& camera, const BoundingSphere& sphere,
                   const std::vector<BatchDraw>& draws,
                   const std::vector<MaterialPushConstants>& materials,
                   const SceneResources& resources) const;

  std::unique_ptr<VulkanContext> ctx_;
  BakePipeline pipeline_;
  SupersampleResolve resolve_;
  CommandRunner runner_;
  const Scene* kept_scene_ = nullptr;
  std::unique_ptr<SceneResources> kept_resources_;  // of kept_scene_
  std::unique_ptr<gpu::ImpostorViewKernel> view_kernel_;  // made by the first UploadImpostor
};

absl::StatusOr<const SceneResources*> AtlasRendererVulkan::ResourcesFor(const Scene& scene,
                                                                        const gpu::TextureFilter& filter,
                                                                        std::unique_ptr<SceneResources>* fresh) {
  const bool keep = kept_scene_ == &scene;
  if (keep && kept_resources_ != nullptr) {
    // Render left the device idle, so the old sets are free to replace.
    if (absl::Status rebound = kept_resources_->UseFilter(*ctx_, pipeline_, scene, filter); !rebound.ok()) {
      kept_resources_.reset();  // half rebound: the next Render uploads afresh
      return rebound;
    }
    return kept_resources_.get();
  }
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(*fresh, SceneResources::Upload(*ctx_, runner_, pipeline_, scene, filter));
  if (!keep) return fresh->get();
  kept_resources_ = std::move(*fresh);
  return kept_resources_.get();
}

void AtlasRendererVulkan::RecordFrame(VkCommandBuffer cmd, const FrameCamera& camera,
                                      const BoundingSphere& sphere,
                                      const std::vector<BatchDraw>& draws,
                                      const std::vector<MaterialPushConstants>& materials,
                                      const SceneResources& resources) const {
  const TileRect& t = camera.tile;
  // The viewport maps clip x,y in [-1, 1] onto the tile, exactly the pixel
  // mapping of frame_camera.h; the scissor keeps stray fragments (clipping
  // guard bands) out of the neighbouring tiles.
  const VkViewport viewport{static_cast<float>(t.x),
                            static_cast<float>(t.y),
                            static_cast<float>(t.width),
                            static_cast<float>(t.height),
                            0.0f,
                            1.0f};
  const VkRect2D scissor{{t.x, t.y},
                         {static_cast<uint32_t>(t.width), static_cast<uint32_t>(t.height)}};
  vkCmdSetViewport(cmd, 0, 1, &viewport);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
  const glm::mat4 view_projection = FrameViewProjection(camera, sphere);
  vkCmdPushConstants(cmd, pipeline_.layout(), VK_SHADER_STAGE_VERTEX_BIT, gpu::kFramePushOffset,
                     gpu::kFramePushSize, &view_projection);

  int bound_material = -1;
  for (const BatchDraw& d : draws) {
    if (d.material != bound_material) {
      const VkDescriptorSet set = resources.material_set(d.material);
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_.layout(), 0, 1, &set,
                              0, nullptr);
      vkCmdPushConstants(cmd, pipeline_.layout(), VK_SHADER_STAGE_FRAGMENT_BIT,
                         gpu::kMaterialPushOffset, sizeof(MaterialPushConstants),
                         &materials[d.material]);
      bound_material = d.material;
    }
    vkCmdSetCullMode(cmd, d.cull);
    vkCmdSetFrontFace(cmd, d.front_face);
    vkCmdDrawIndexed(cmd, d.index_count, 1, d.first_index, 0, 0);
  }
}

absl::StatusOr<AtlasImages> AtlasRendererVulkan::Render(
    const Scene& scene, const BoundingSphere& sphere, const std::vector<FrameCamera>& cameras,
    int atlas_size, const std::function<void(double)>& progress, RenderTimings* timings) {
  IMPOSTOR_GPU_RETURN_IF_ERROR(gpu::ValidateRenderRequest(scene, sphere, cameras, atlas_size,
                                                          ctx_->limits().maxImageDimension2D));
  RenderTimings local_timings;
  RenderTimings& times = timings != nullptr ? *timings : local_timings;
  times = RenderTimings{};

  std::unique_ptr<SceneResources> fresh_resources;
  std::optional<AtlasTargets> targets;
  IdleBeforeRelease idle_guard(ctx_->device());

  auto phase_start = std::chrono::steady_clock::now();
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(
      const SceneResources* resources,
      ResourcesFor(scene, gpu::TextureFilterFor(supersampling(), ctx_->max_anisotropy()), &fresh_resources));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(targets,
                                AtlasTargets::Create(*ctx_, static_cast<uint32_t>(atlas_size),
                                                     emissive_requested(),
                                                     static_cast<uint32_t>(device_resolve_factor())));
  times.upload_seconds = SecondsSince(phase_start);

  std::vector<MaterialPushConstants> materials;
  materials.reserve(scene.materials.size());
  for (const SceneMaterial& m : scene.materials) {
    materials.push_back(gpu::MakeMaterialPushConstants(m));
  }
  std::vector<BatchDraw> draws;
  draws.reserve(scene.batches.size());
  for (const SceneBatch& b : scene.batches) {
    if (b.index_count == 0) continue;
    // glTF front faces are counter-clockwise; FrameViewProjection keeps
    // (right, up, toward camera) right-handed with y flipped to Vulkan's
    // y-down framebuffer, so CCW in scene space stays CCW on screen.
    draws.push_back(
        {b.first_index, b.index_count, b.material,
         scene.materials[b.material].double_sided ? VkCullModeFlags{VK_CULL_MODE_NONE}
                                                  : VkCullModeFlags{VK_CULL_MODE_BACK_BIT},
         b.flipped_winding ? VK_FRONT_FACE_CLOCKWISE : VK_FRONT_FACE_COUNTER_CLOCKWISE});
  }

  const size_t triangles = std::max<size_t>(1, scene.TriangleCount());
  const int frames_per_chunk =
      static_cast<int>(std::clamp<size_t>(kTrianglesPerChunk / triangles, 1, kMaxFramesPerChunk));
  const int frame_count = static_cast<int>(cameras.size());

  phase_start = std::chrono::steady_clock::now();
  for (int first = 0; first < frame_count; first += frames_per_chunk) {
    const int last = std::min(frame_count, first + frames_per_chunk);
    IMPOSTOR_GPU_ASSIGN_OR_RETURN(VkCommandBuffer cmd, runner_.Begin());
    targets->BeginRendering(cmd, /*first_use=*/first == 0);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_.pipeline());
    const VkBuffer vertex_buffer = resources->vertex_buffer();
    const VkDeviceSize offset = 0;
    vkCmdBindVertexBuffers(cmd, 0, 1, &vertex_buffer, &offset);
    vkCmdBindIndexBuffer(cmd, resources->index_buffer(), 0, VK_INDEX_TYPE_UINT32);
    for (int f = first; f < last; ++f) {
      RecordFrame(cmd, cameras[f], sphere, draws, materials, *resources);
    }
    vkCmdEndRendering(cmd);
    IMPOSTOR_GPU_RETURN_IF_ERROR(runner_.SubmitAndWait());
    if (progress) progress(static_cast<double>(last) / frame_count);
    if (cancel_requested()) {
      return absl::CancelledError(absl::StrCat("render cancelled after ", last, " of ", frame_count, " frames"));
    }
  }
  times.render_seconds = SecondsSince(phase_start);

  phase_start = std::chrono::steady_clock::now();
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(VkCommandBuffer cmd, runner_.Begin());
  targets->RecordReadback(cmd, &resolve_);
  IMPOSTOR_GPU_RETURN_IF_ERROR(runner_.SubmitAndWait());
  AtlasImages images;
  IMPOSTOR_GPU_RETURN_IF_ERROR(targets->CopyToHost(&images));
  times.readback_seconds = SecondsSince(phase_start);

  spdlog::debug(
      "gpu: baked {} frames of {} triangles into {}^2 ({} frames/submit): upload {:.3f}s, "
      "render {:.3f}s, readback {:.3f}s",
      frame_count, scene.TriangleCount(), atlas_size, frames_per_chunk, times.upload_seconds,
      times.render_seconds, times.readback_seconds);
  return images;
}

}  // namespace

absl::StatusOr<std::unique_ptr<AtlasRenderer>> AtlasRenderer::Create(
    const std::string& preferred_device) {
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(std::unique_ptr<VulkanContext> ctx,
                                VulkanContext::Create(preferred_device));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(BakePipeline pipeline, BakePipeline::Create(*ctx));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(SupersampleResolve resolve, SupersampleResolve::Create(*ctx));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(CommandRunner runner, CommandRunner::Create(*ctx));
  return std::unique_ptr<AtlasRenderer>(new AtlasRendererVulkan(std::move(ctx), std::move(pipeline),
                                                                std::move(resolve), std::move(runner)));
}

}  // namespace impostor
