// How much memory a bake holds at its peak, from its normalised parameters
// alone, so that the server leases a job only to a worker that can hold it
// (common/request/worker_fit.h) and a worker refuses one it could never
// finish before it downloads or renders anything (worker/bake_memory_check.h).
//
// Counted: what atlas_bake.cc and the code it calls allocate in proportion
// to the atlas: the render targets at resolution x supersampling
// (atlas_targets.cc), the readback buffers, the CPU maps (AtlasImages), the
// quality pass's copy of the maps and its device upload (quality_pass.cc),
// and the encoders' buffers (png_encoder.cc, or for KTX2 the mip chains of
// ktx2_maps.cc and the basisu processes it runs). The phases do not all
// overlap: the targets and readback buffers are gone when Render returns,
// before the post-process starts; the encoders run beside the quality pass.
//
// Not counted: the mesh, its textures and its device upload (bounded by the
// load limits, GltfLoadLimits) and the process's fixed cost (the Vulkan
// driver, code): small next to the atlases this check is for.
//
// Checked against the peak resident memory of real atlas bakes on lavapipe
// (tests/bake/bake_memory_test.cc: the estimate is 1.0-1.3 times the peak).
// A LOD chain is estimated as its impostor atlas (its meshes are the
// mesh's size); cards and surfels as an atlas at supersampling 1 without a
// quality pass (surfels: plus their samples). Those three are not measured.
//
// Pure functions; thread-safe.
#ifndef IMPOSTOR_COMMON_REQUEST_BAKE_MEMORY_ESTIMATE_H_
#define IMPOSTOR_COMMON_REQUEST_BAKE_MEMORY_ESTIMATE_H_

#include <cstdint>
#include <string>
#include <string_view>

#include "impostor/v1/types.pb.h"

namespace impostor {

// What the bake renders on, as far as memory goes.
enum class BakeDevice {
  kDedicatedGpu,   // a GPU with memory of its own: device allocations are not the host's
  kIntegratedGpu,  // a GPU in system memory: device allocations are host memory too
  kCpu,            // lavapipe: device allocations are host memory, and the
                   // quality pass draws its impostor views on the CPU
};

// The BakeDevice of a DeviceInfo::type ("discrete", "integrated", "cpu"...).
BakeDevice BakeDeviceOfType(std::string_view device_type);

struct BakeMemoryEstimate {
  // The bake's peak in host memory: this process and the encoder processes
  // it runs at the same time, bytes.
  int64_t host_bytes = 0;
  // The bake's peak in device memory, bytes (on an integrated GPU or the
  // CPU also part of host_bytes).
  int64_t device_bytes = 0;
  // The largest single device allocation, bytes, what it is ("normal_depth
  // render target") and its shape ("16384 px square, 8 bytes a texel").
  int64_t largest_allocation_bytes = 0;
  std::string largest_allocation;
  std::string largest_allocation_shape;
};

// The estimate for `normalised` (NormalizeParameters' output; an unset
// supersampling counts as 1, as BakeAtlas renders it) on `device`.
BakeMemoryEstimate EstimateBakeMemory(const v1::BakeParameters& normalised, BakeDevice device);

// What is baked, with the parameters that drive its memory, for messages:
// "an atlas of 16384 px at supersampling 2 (frames 64)".
std::string DescribeBake(const v1::BakeParameters& normalised);

// "17.2 GB", "46 MB", "3.1 MB", "512 bytes": decimal units, as people read them.
std::string MemoryAmount(int64_t bytes);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_REQUEST_BAKE_MEMORY_ESTIMATE_H_
