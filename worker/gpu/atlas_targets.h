// The render targets of one bake (albedo_alpha, normal_depth, orm colour
// images and a D32 depth image, all atlas_size squared) and the host-visible
// buffers they are read back into, plus the commands that move them between
// uses: first-use layout setup with the clear values from atlas_renderer.h,
// chunk-to-chunk dependencies, and the final copy to the host. With a
// resolve factor above 1 the readback buffers hold the maps filtered down by
// that factor on the device (supersample_resolve.h), not the targets as
// rendered.
//
// Ownership: owns the images and buffers; the owner must have waited for the
// last submission that used them. Thread-safety: none.
#ifndef IMPOSTOR_WORKER_GPU_ATLAS_TARGETS_H_
#define IMPOSTOR_WORKER_GPU_ATLAS_TARGETS_H_

#include <vulkan/vulkan.h>

#include <cstdint>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "worker/gpu/atlas_renderer.h"
#include "worker/gpu/gpu_buffer.h"
#include "worker/gpu/gpu_image.h"
#include "worker/gpu/supersample_resolve.h"
#include "worker/gpu/vulkan_context.h"

namespace impostor::gpu {

class AtlasTargets {
 public:
  // Allocates everything up front so an atlas too large for the device
  // fails (RESOURCE_EXHAUSTED) before any frame is rendered.
  // `emissive`: also the fourth (emissive) target; without it the fourth
  // attachment of the bake pipeline is bound to no image (writes dropped).
  // `resolve_factor` (a divisor of `size`): the maps read back are
  // size / resolve_factor squared, filtered down on the device.
  static absl::StatusOr<AtlasTargets> Create(const VulkanContext& ctx, uint32_t size,
                                             bool emissive = false, uint32_t resolve_factor = 1);

  AtlasTargets(AtlasTargets&&) noexcept = default;
  AtlasTargets& operator=(AtlasTargets&&) noexcept = default;

  // Starts dynamic rendering over the whole atlas. The first call of a bake
  // (`first_use`) moves the images out of UNDEFINED and clears them; later
  // calls wait for the previous chunk's attachment writes and load them.
  void BeginRendering(VkCommandBuffer cmd, bool first_use) const;

  // After the last chunk: copies the colour images into the readback
  // buffers (or, with a resolve factor above 1, filters them down into them
  // with `resolve`, which must then be non-null) and makes the result
  // visible to the host.
  void RecordReadback(VkCommandBuffer cmd, const SupersampleResolve* resolve = nullptr) const;

  // After RecordReadback's submission completed: fills `out`.
  absl::Status CopyToHost(AtlasImages* out) const;

  uint32_t size() const { return size_; }

 private:
  AtlasTargets() = default;

  void RecordResolve(VkCommandBuffer cmd, const SupersampleResolve& resolve) const;

  uint32_t size_ = 0;
  uint32_t resolve_factor_ = 1;
  uint32_t out_size_ = 0;  // size_ / resolve_factor_: the maps read back
  // UNORM views of the sRGB targets: the resolve reads their bytes.
  VkImageView albedo_unorm_ = VK_NULL_HANDLE;
  VkImageView emissive_unorm_ = VK_NULL_HANDLE;
  GpuImage albedo_;
  GpuImage normal_depth_;
  GpuImage orm_;
  GpuImage emissive_;  // null image unless requested
  GpuImage depth_;
  GpuBuffer albedo_readback_;
  GpuBuffer normal_depth_readback_;
  GpuBuffer orm_readback_;
  GpuBuffer emissive_readback_;
  bool has_emissive_ = false;
};

}  // namespace impostor::gpu

#endif  // IMPOSTOR_WORKER_GPU_ATLAS_TARGETS_H_
