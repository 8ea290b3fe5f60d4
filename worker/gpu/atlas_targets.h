// The render targets of one bake (albedo_alpha, normal_depth, orm colour
// images and a D32 depth image, all atlas_size squared) and the host-visible
// buffers they are read back into, plus the commands that move them between
// uses: first-use layout setup with the clear values from atlas_renderer.h,
// chunk-to-chunk dependencies, and the final copy to the host.
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
#include "worker/gpu/vulkan_context.h"

namespace impostor::gpu {

class AtlasTargets {
 public:
  // Allocates everything up front so an atlas too large for the device
  // fails (RESOURCE_EXHAUSTED) before any frame is rendered.
  // `emissive`: also the fourth (emissive) target; without it the fourth
  // attachment of the bake pipeline is bound to no image (writes dropped).
  static absl::StatusOr<AtlasTargets> Create(const VulkanContext& ctx, uint32_t size,
                                             bool emissive = false);

  AtlasTargets(AtlasTargets&&) noexcept = default;
  AtlasTargets& operator=(AtlasTargets&&) noexcept = default;

  // Starts dynamic rendering over the whole atlas. The first call of a bake
  // (`first_use`) moves the images out of UNDEFINED and clears them; later
  // calls wait for the previous chunk's attachment writes and load them.
  void BeginRendering(VkCommandBuffer cmd, bool first_use) const;

  // After the last chunk: copies the three colour images into the readback
  // buffers and makes the copies visible to the host.
  void RecordReadback(VkCommandBuffer cmd) const;

  // After RecordReadback's submission completed: fills `out`.
  absl::Status CopyToHost(AtlasImages* out) const;

  uint32_t size() const { return size_; }

 private:
  AtlasTargets() = default;

  uint32_t size_ = 0;
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
