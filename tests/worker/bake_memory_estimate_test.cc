// The arithmetic of common/request/bake_memory_estimate.h, case by case. How
// well it matches real bakes is tests/bake/bake_memory_test.cc's (gpu).
#include "common/request/bake_memory_estimate.h"

#include <cstdint>
#include <string>

#include <gtest/gtest.h>

#include "common/request/bake_request.h"

namespace impostor {
namespace {

constexpr int64_t kMiB = 1 << 20;
constexpr int64_t kSmallBuffers = 16 * kMiB;
// The quality pass's largest mesh-view render at 1024 px and above: the
// antialiased pop orbit, 9 x 9 tiles of 64 px at 3 x 3 samples, three maps
// (16 bytes a texel) and depth (4). Host memory on lavapipe and integrated
// GPUs, device memory everywhere.
constexpr int64_t kQualityViews = int64_t{9 * 64 * 3} * (9 * 64 * 3) * 20;

v1::BakeParameters Normalised(uint32_t resolution, uint32_t supersampling, uint32_t frames = 8) {
  v1::BakeParameters in;
  in.set_resolution(resolution);
  in.set_supersampling(supersampling);
  in.set_frames(frames);
  absl::StatusOr<v1::BakeParameters> p = NormalizeParameters(in);
  EXPECT_TRUE(p.ok()) << p.status();
  return p.value_or(in);
}

struct Case {
  std::string name;
  v1::BakeParameters parameters;
  BakeDevice device;
  int64_t host;
  int64_t device_bytes;
};

TEST(BakeMemoryEstimate, EachPhaseAsTheCodeAllocatesIt) {
  const int64_t r1k = 1024 * 1024, r2k = 2048 * 2048, r4k = 4096 * 4096;
  v1::BakeParameters emissive = Normalised(1024, 1);
  emissive.set_emissive(true);
  v1::BakeParameters no_quality = Normalised(1024, 1);
  no_quality.set_quality_views(0);
  v1::BakeParameters ktx2 = Normalised(1024, 1);
  ktx2.set_texture_format(v1::TEXTURE_FORMAT_KTX2);
  const Case cases[] = {
      // Post phase on the CPU: maps + the quality pass's copy + the PNG
      // encoders (2 x the maps) + its mesh views, above the render phase's
      // targets (albedo 4 + normal_depth 8 + orm 4 + depth 4 bytes at
      // 2048 px) + readback + maps (16 bytes at 1024 px).
      {"lavapipe 1024 px ss 2", Normalised(1024, 2), BakeDevice::kCpu, 4 * r1k * 16 + kQualityViews + kSmallBuffers,
       r2k * 20 + r1k * 16},
      // On a GPU with its own memory only the readback and the maps are the
      // host's; the post phase is larger then: maps + the quality pass's
      // copy + the PNG encoders (2 x the maps) + its staging buffer.
      {"discrete 1024 px ss 2", Normalised(1024, 2), BakeDevice::kDedicatedGpu,
       r1k * 16 + r1k * 16 + 2 * r1k * 16 + r1k * 8 + kSmallBuffers, r2k * 20},
      // Post phase on lavapipe: no upload for the quality pass.
      {"lavapipe 4096 px ss 1", Normalised(4096, 1), BakeDevice::kCpu, 4 * r4k * 16 + kQualityViews + kSmallBuffers,
       r4k * 20 + r4k * 16},
      // An integrated GPU: the targets are host memory, and so is the
      // quality pass's upload and mesh views; on the device the upload and
      // the views outweigh the render.
      {"integrated 1024 px ss 1", Normalised(1024, 1), BakeDevice::kIntegratedGpu,
       r1k * 16 + r1k * 16 + 2 * r1k * 16 + r1k * 8 + r1k * 16 + kQualityViews + kSmallBuffers,
       r1k * 16 + kQualityViews},
      // Emissive: a fifth target and a fourth map (4 bytes each).
      {"lavapipe 1024 px ss 1 emissive", emissive, BakeDevice::kCpu,
       r1k * 20 + r1k * 16 + 2 * r1k * 16 + kQualityViews + kSmallBuffers, kQualityViews},
      // No quality pass: the encoders alone after the render.
      {"lavapipe 1024 px ss 1 no quality pass", no_quality, BakeDevice::kCpu, r1k * 20 + 2 * r1k * 16 + kSmallBuffers,
       r1k * 20 + r1k * 16},
      // KTX2: mip chains (27 bytes a texel), each level as a PNG (24) and
      // three basisu processes (3 x 27).
      {"lavapipe 1024 px ss 1 ktx2", ktx2, BakeDevice::kCpu,
       r1k * 16 + r1k * 16 + r1k * (27 + 24 + 81) + kQualityViews + kSmallBuffers, kQualityViews},
  };
  for (const Case& c : cases) {
    const BakeMemoryEstimate e = EstimateBakeMemory(c.parameters, c.device);
    EXPECT_EQ(e.host_bytes, c.host) << c.name;
    EXPECT_EQ(e.device_bytes, c.device_bytes) << c.name;
  }
}

TEST(BakeMemoryEstimate, TheLargestAllocationIsTheNormalDepthTarget) {
  const BakeMemoryEstimate e = EstimateBakeMemory(Normalised(8192, 2), BakeDevice::kDedicatedGpu);
  EXPECT_EQ(e.largest_allocation_bytes, int64_t{16384} * 16384 * 8);
  EXPECT_EQ(e.largest_allocation, "normal_depth render target");
  EXPECT_EQ(e.largest_allocation_shape, "16384 px square, 8 bytes a texel");
}

TEST(BakeMemoryEstimate, TheLargestRequestNeedsWhatTheRedTeamMeasured) {
  // impostor bake --frames 64 --resolution 16384 (the largest the server
  // accepts, supersampling 1): 15-18 GB of host memory on lavapipe.
  const BakeMemoryEstimate e = EstimateBakeMemory(Normalised(16384, 1, 64), BakeDevice::kCpu);
  EXPECT_GE(e.host_bytes, 15'000'000'000);
  EXPECT_LE(e.host_bytes, 18'000'000'000);
}

TEST(BakeMemoryEstimate, ProductsWithoutSupersamplingRenderAtTheResolution) {
  v1::BakeParameters in;
  in.set_product(v1::PRODUCT_SURFELS);
  in.set_resolution(2048);
  absl::StatusOr<v1::BakeParameters> surfels = NormalizeParameters(in);
  ASSERT_TRUE(surfels.ok()) << surfels.status();
  const BakeMemoryEstimate e = EstimateBakeMemory(*surfels, BakeDevice::kDedicatedGpu);
  EXPECT_EQ(e.largest_allocation_bytes, int64_t{2048} * 2048 * 8);
  // The maps and, per texel at most, a 48-byte surfel over pi/4 of it.
  EXPECT_EQ(e.host_bytes, int64_t{2048} * 2048 * (16 + 37) + kSmallBuffers);
}

}  // namespace
}  // namespace impostor
