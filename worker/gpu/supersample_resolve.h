// The compute pipeline that filters supersampled atlas targets down on the
// device (shaders/supersample_resolve.comp; the semantics and the CPU
// reference are worker/output/supersample.h), writing the final-size maps
// straight into the host-visible readback buffers. Reading back only the
// final maps saves factor^2 - 1 of the readback bytes and the CPU filter
// pass: on lavapipe, the largest cost of a supersampled bake before this.
//
// Ownership: owns its pipeline (compute_pipeline.h) and sampler; must be
// destroyed before the VulkanContext. Thread-safety: one
// thread; Record rewrites the single descriptor set, so the previous
// submission that used it must have completed (the renderer waits on every
// submission).
#ifndef IMPOSTOR_WORKER_GPU_SUPERSAMPLE_RESOLVE_H_
#define IMPOSTOR_WORKER_GPU_SUPERSAMPLE_RESOLVE_H_

#include <vulkan/vulkan.h>

#include <cstdint>

#include "absl/status/statusor.h"
#include "worker/gpu/compute_pipeline.h"
#include "worker/gpu/vk_handle.h"
#include "worker/gpu/vulkan_context.h"

namespace impostor::gpu {

// What one resolve reads and writes. Views must be in
// SHADER_READ_ONLY_OPTIMAL; albedo and emissive views are UNORM views of the
// sRGB images (the shader decodes the bytes itself). Buffers are tightly
// packed RGBA8 (RGBA16 for normal_depth) of out_width x out_height texels.
// Without emissive, emissive_view and emissive_buffer may be any valid
// view/buffer (they are bound but never touched).
struct ResolveBindings {
  VkImageView albedo_view, normal_depth_view, orm_view, emissive_view;
  VkBuffer albedo_buffer, normal_depth_buffer, orm_buffer, emissive_buffer;
  uint32_t factor;
  uint32_t out_width, out_height;
  bool emissive;
};

class SupersampleResolve {
 public:
  static absl::StatusOr<SupersampleResolve> Create(const VulkanContext& ctx);

  SupersampleResolve() = default;
  SupersampleResolve(SupersampleResolve&&) noexcept = default;
  SupersampleResolve& operator=(SupersampleResolve&&) noexcept = default;

  // Points the descriptor set at `b` and records the dispatch. The caller
  // records the barriers around it.
  void Record(VkCommandBuffer cmd, const ResolveBindings& b) const;

 private:
  UniqueSampler sampler_;
  ComputePipeline pipeline_;
};

}  // namespace impostor::gpu

#endif  // IMPOSTOR_WORKER_GPU_SUPERSAMPLE_RESOLVE_H_
