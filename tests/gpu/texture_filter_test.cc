// The texture filtering rule of the bake (worker/gpu/texture_filter.h):
// supersampled bakes sample trilinear with a sharpening bias, single-sample
// bakes anisotropically where the device allows it (never a CPU device).
#include "worker/gpu/texture_filter.h"

#include <gtest/gtest.h>

#include "worker/gpu/vulkan_context.h"

namespace impostor::gpu {
namespace {

TEST(TextureFilter, SupersampledBakesUseBiasedTrilinearOnEveryDevice) {
  for (int factor : {2, 3, 4}) {
    for (float device : {0.0f, 1.0f, 8.0f, 16.0f}) {
      const TextureFilter f = TextureFilterFor(factor, device);
      EXPECT_FALSE(f.anisotropy) << factor << " " << device;
      EXPECT_EQ(f.max_anisotropy, 1.0f);
      EXPECT_EQ(f.mip_lod_bias, kSupersampledLodBias);
    }
  }
  EXPECT_LT(kSupersampledLodBias, 0.0f);  // sharper, never blurrier
}

TEST(TextureFilter, SingleSampleBakesKeepTheDevicesAnisotropy) {
  const TextureFilter f = TextureFilterFor(1, 8.0f);
  EXPECT_TRUE(f.anisotropy);
  EXPECT_EQ(f.max_anisotropy, 8.0f);
  EXPECT_EQ(f.mip_lod_bias, 0.0f);
}

TEST(TextureFilter, NoAnisotropyWhereTheDeviceHasNone) {
  for (float device : {0.0f, 1.0f}) {
    const TextureFilter f = TextureFilterFor(1, device);
    EXPECT_FALSE(f.anisotropy);
    EXPECT_EQ(f.max_anisotropy, 1.0f);
    EXPECT_EQ(f.mip_lod_bias, 0.0f);
  }
}

TEST(TextureFilter, FactorsBelowOneCountAsNoSupersampling) {
  for (int factor : {0, -3}) {
    const TextureFilter f = TextureFilterFor(factor, 8.0f);
    EXPECT_TRUE(f.anisotropy) << factor;
    EXPECT_EQ(f.mip_lod_bias, 0.0f);
  }
}

// On a CPU device (lavapipe) the context enables no anisotropy, so even a
// one-sample bake filters by mip level: lavapipe's anisotropic filtering
// costs in proportion to the footprint (a 72-view pop orbit of a texture
// repeated 4000 times took 20-70 s instead of 0.3-0.9 s).
TEST(TextureFilter, CpuDevicesSampleWithoutAnisotropy) {
  auto ctx = VulkanContext::Create("");
  if (!ctx.ok()) GTEST_SKIP() << "no Vulkan device: " << ctx.status();
  if ((*ctx)->info().type != "cpu") GTEST_SKIP() << "not a CPU device: " << (*ctx)->info().name;
  EXPECT_LE((*ctx)->max_anisotropy(), 1.0f);
  EXPECT_FALSE(TextureFilterFor(1, (*ctx)->max_anisotropy()).anisotropy);
}

}  // namespace
}  // namespace impostor::gpu
