// The DeviceImpostor of AtlasRendererVulkan: the atlas's three maps as
// sampled images and shaders/impostor_runtime_view.comp, one dispatch per
// view, views batched into one submission and one host-visible buffer.
//
// Why: on a GPU the quality pass's impostor side (held-out views and the pop
// orbit, each in depth and plain mode) cost most of the pass when drawn by
// the CPU reference renderer (H100 with 16 cores: 0.40 s of a 0.54 s pass,
// beside the PNG encoders that want the same cores); the runtime shader
// draws them in milliseconds. On lavapipe the shader is slower than the C++
// (the quality pass keeps the C++ there: quality_pass.h).
//
// Ownership: owns its images, command runner and output buffer; borrows the
// VulkanContext and the kernel (its renderer's), which must outlive it.
#ifndef IMPOSTOR_WORKER_GPU_DEVICE_IMPOSTOR_VIEWS_H_
#define IMPOSTOR_WORKER_GPU_DEVICE_IMPOSTOR_VIEWS_H_

#include <memory>
#include <vector>

#include "absl/status/statusor.h"
#include "common/runtime/reference_renderer.h"
#include "worker/gpu/atlas_renderer.h"
#include "worker/gpu/command_runner.h"
#include "worker/gpu/compute_pipeline.h"
#include "worker/gpu/gpu_buffer.h"
#include "worker/gpu/gpu_image.h"
#include "worker/gpu/vk_handle.h"
#include "worker/gpu/vulkan_context.h"

namespace impostor::gpu {

// The runtime view kernel (impostor_runtime_view.comp) and its sampler,
// made once per renderer and shared by every DeviceImpostorViews: compiling
// the shader is the costly part of drawing views on a GPU (an H100's driver
// took 1.4 s on a host's first bake, ~0.05 s from its own cache after).
// Thread-safety: as the renderer; each use binds its own atlas into the one
// descriptor set, so uses must not overlap (every RenderViews waits).
class ImpostorViewKernel {
 public:
  static absl::StatusOr<std::unique_ptr<ImpostorViewKernel>> Create(const VulkanContext& ctx);
  const ComputePipeline& pipeline() const { return pipeline_; }
  VkSampler sampler() const { return sampler_.get(); }

 private:
  ImpostorViewKernel() = default;
  ComputePipeline pipeline_;
  UniqueSampler sampler_;
};

// The output buffer holds this many bytes at most; more views than fit are
// drawn in several submissions (a 3 x 3 supersampled pop orbit is ~130 MB).
inline constexpr VkDeviceSize kMaxViewBatchBytes = VkDeviceSize{32} << 20;

class DeviceImpostorViews final : public DeviceImpostor {
 public:
  // Borrows `kernel` (it must outlive the result).
  static absl::StatusOr<std::unique_ptr<DeviceImpostorViews>> Create(const VulkanContext& ctx,
                                                                     const ImpostorViewKernel& kernel,
                                                                     const ImpostorAtlas& atlas);

  absl::StatusOr<std::vector<ViewImages>> RenderViews(const std::vector<FrameCamera>& cameras, int pixels,
                                                      const ReferenceRenderOptions& options) override;

 private:
  DeviceImpostorViews(const VulkanContext& ctx, const ImpostorViewKernel& kernel) : ctx_(ctx), kernel_(kernel) {}
  // Draws cameras[first, first + count) into the output buffer and decodes them.
  absl::Status RenderBatch(const std::vector<FrameCamera>& cameras, size_t first, size_t count, int pixels,
                           const ReferenceRenderOptions& options, std::vector<ViewImages>* out);

  const VulkanContext& ctx_;
  const ImpostorViewKernel& kernel_;
  ViewLayout layout_;
  int tile_size_ = 0;
  bool has_orm_ = false;
  CommandRunner runner_;
  GpuImage albedo_, normal_depth_, orm_;
  GpuBuffer pixels_;  // grown on demand, up to kMaxViewBatchBytes
};

}  // namespace impostor::gpu

#endif  // IMPOSTOR_WORKER_GPU_DEVICE_IMPOSTOR_VIEWS_H_
