// The cross-fade at the LOD switch on a Vulkan device (lavapipe suffices):
// shaders/impostor_crossfade.glsl's dither against the C++ SDK's
// (impostor/lod.h) bit for bit over a grid of pixels (negative ones too),
// seeds and fade factors, including t just either side of every threshold;
// mesh and impostor complementary at every t; the impostor's share of every
// aligned 4 x 4 block within 1/16 of t; and the reference material's colour
// pass and shadow caster (impostor_material_view.comp) keeping exactly the
// pixels the SDK gives the impostor.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "common/atlas/frame_camera.h"
#include "common/runtime/reference_renderer.h"
#include "common/runtime/virtual_plane.h"
#include "impostor/lod.h"
#include "shaders/impostor_crossfade_check_comp.h"
#include "shaders/impostor_material_view_comp.h"
#include "tests/runtime/compute_kernel.h"
#include "tests/runtime/synthetic_atlas.h"
#include "worker/gpu/gpu_buffer.h"
#include "worker/gpu/vulkan_context.h"

namespace impostor {
namespace {

using gpu::GpuBuffer;
using ::impostor::testing::RunKernel;
using ::impostor::testing::UploadImage;

constexpr uint32_t kSeeds[] = {0u, 1u, 2u, 3u, 7u, 16u, 1000u, 12345u, 2654435769u, 0xffffffffu};

struct Case {
  int32_t x, y;
  uint32_t seed;
  float t;
};
static_assert(sizeof(Case) == 16);

struct Decision {
  uint32_t threshold_bits, impostor, mesh, unused;
};

// Every threshold (l + 0.5) / 16, one float step either side of it, steps
// of 1/64 and values outside 0..1.
std::vector<float> FadeFactors() {
  std::vector<float> t = {-1.0f, -0.0f, 1.5f, std::numeric_limits<float>::infinity()};
  for (int k = 0; k <= 64; ++k) t.push_back(k / 64.0f);
  for (int l = 0; l < 16; ++l) {
    const float h = (l + 0.5f) / 16.0f;
    t.push_back(std::nextafter(h, 0.0f));
    t.push_back(std::nextafter(h, 1.0f));
  }
  return t;
}

class GlslCrossFadeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto ctx = gpu::VulkanContext::Create("");
    // Fails, not skips, without a device (lavapipe is enough): `ctest -LE gpu` opts out.
    ASSERT_TRUE(ctx.ok()) << "no Vulkan device: " << ctx.status();
    ctx_ = std::move(*ctx);
  }

  std::vector<Decision> Decide(const std::vector<Case>& cases) {
    const VkMemoryPropertyFlags host = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT;
    auto in = GpuBuffer::Create(*ctx_, cases.size() * sizeof(Case), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, host, 0,
                                "cases");
    auto out = GpuBuffer::Create(*ctx_, cases.size() * sizeof(Decision), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, host,
                                 VK_MEMORY_PROPERTY_HOST_CACHED_BIT, "decisions");
    EXPECT_TRUE(in.ok() && out.ok());
    if (!in.ok() || !out.ok()) return {};
    std::memcpy(in->mapped(), cases.data(), cases.size() * sizeof(Case));
    EXPECT_TRUE(in->FlushHostWrites().ok());
    const int32_t count = static_cast<int32_t>(cases.size());
    const absl::Status s =
        RunKernel(*ctx_, impostor_crossfade_check_comp, sizeof(impostor_crossfade_check_comp),
                  {{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, in->buffer()}, {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, out->buffer()}},
                  &count, sizeof(count), static_cast<uint32_t>((cases.size() + 63) / 64), 1);
    EXPECT_TRUE(s.ok()) << s;
    EXPECT_TRUE(out->InvalidateForHostRead().ok());
    std::vector<Decision> d(cases.size());
    std::memcpy(d.data(), out->mapped(), d.size() * sizeof(Decision));
    return d;
  }

  std::unique_ptr<gpu::VulkanContext> ctx_;
};

TEST_F(GlslCrossFadeTest, DitherMatchesTheSdkBitForBitAndIsComplementary) {
  std::vector<Case> cases;
  for (uint32_t seed : kSeeds) {
    for (float t : FadeFactors()) {
      for (int y = -5; y < 11; ++y) {
        for (int x = -5; x < 11; ++x) cases.push_back({x, y, seed, t});
      }
      cases.push_back({4097, 65539, seed, t});
      cases.push_back({-70001, 3, seed, t});
    }
  }
  const std::vector<Decision> gpu = Decide(cases);
  ASSERT_EQ(gpu.size(), cases.size());
  int mismatches = 0;
  for (size_t i = 0; i < cases.size() && mismatches < 10; ++i) {
    const Case& c = cases[i];
    const float threshold = sdk::CrossFadeThreshold(c.seed, c.x, c.y);
    uint32_t bits;
    std::memcpy(&bits, &threshold, sizeof(bits));
    const bool imp = sdk::CrossFadeDrawsImpostor(c.t, c.seed, c.x, c.y);
    const bool mesh = sdk::CrossFadeDrawsMesh(c.t, c.seed, c.x, c.y);
    const std::string name = "pixel (" + std::to_string(c.x) + ", " + std::to_string(c.y) + ") seed " +
                             std::to_string(c.seed) + " t " + std::to_string(c.t);
    mismatches += gpu[i].threshold_bits != bits || gpu[i].impostor != imp || gpu[i].mesh != mesh;
    EXPECT_EQ(gpu[i].threshold_bits, bits) << name;
    EXPECT_EQ(gpu[i].impostor, imp ? 1u : 0u) << name;
    EXPECT_EQ(gpu[i].mesh, mesh ? 1u : 0u) << name;
    EXPECT_NE(gpu[i].impostor, gpu[i].mesh) << name << ": drawn twice or by neither";
  }
  std::printf("[ figures  ] cross-fade dither: %zu cases, GLSL == C++ bit for bit\n", cases.size());
}

// The impostor's share of each aligned 4 x 4 block, from the shader's
// decisions: within 1/16 of t (1/32 in fact), exactly t at t = k / 16.
TEST_F(GlslCrossFadeTest, ImpostorShareOfEveryBlockIsT) {
  std::vector<Case> cases;
  std::vector<float> ts;
  for (int k = 0; k <= 64; ++k) ts.push_back(k / 64.0f);
  for (uint32_t seed : kSeeds) {
    for (float t : ts) {
      for (int y = 0; y < 8; ++y) {
        for (int x = 0; x < 8; ++x) cases.push_back({x + 40, y - 4, seed, t});
      }
    }
  }
  const std::vector<Decision> gpu = Decide(cases);
  ASSERT_EQ(gpu.size(), cases.size());
  double worst = 0;
  size_t i = 0;
  for (uint32_t seed : kSeeds) {
    for (float t : ts) {
      int block[2][2] = {};
      for (int y = 0; y < 8; ++y) {
        for (int x = 0; x < 8; ++x) block[y / 4][x / 4] += static_cast<int>(gpu[i++].impostor);
      }
      for (int b = 0; b < 4; ++b) {
        const double share = block[b / 2][b % 2] / 16.0;
        worst = std::max(worst, std::abs(share - t));
        EXPECT_LE(std::abs(share - t), 1.0 / 16.0) << "seed " << seed << " t " << t << " block " << b;
        if (std::floor(t * 16.0f) == t * 16.0f) EXPECT_EQ(share, t) << "seed " << seed << " t " << t;
      }
    }
  }
  std::printf("[ figures  ] cross-fade: impostor share of a 4x4 block vs t, largest difference %.4f\n", worst);
}

// impostor_material_view.comp with the fade on: the colour pass and the
// shadow caster each keep exactly their unfaded coverage where the SDK gives
// the pixel to the impostor, and nothing elsewhere.
TEST_F(GlslCrossFadeTest, ColourPassAndShadowCasterKeepTheSameShare) {
  constexpr int kPixels = 128;
  const ViewLayout layout{LayoutKind::kOctahedral, 8, 0};
  const ImpostorAtlas atlas = ::impostor::testing::BakeSyntheticAtlas(layout, 512);
  VkSamplerCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO;
  info.magFilter = info.minFilter = VK_FILTER_NEAREST;
  info.addressModeU = info.addressModeV = info.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  VkSampler sampler = VK_NULL_HANDLE;
  ASSERT_EQ(vkCreateSampler(ctx_->device(), &info, nullptr, &sampler), VK_SUCCESS);
  const int size = atlas.resolution;
  auto albedo = UploadImage(*ctx_, VK_FORMAT_R8G8B8A8_SRGB, size, size, atlas.albedo_alpha.data(),
                            atlas.albedo_alpha.size());
  auto nd = UploadImage(*ctx_, VK_FORMAT_R16G16B16A16_UNORM, size, size, atlas.normal_depth.data(),
                        atlas.normal_depth.size() * sizeof(uint16_t));
  auto orm = UploadImage(*ctx_, VK_FORMAT_R8G8B8A8_UNORM, size, size, atlas.orm.data(), atlas.orm.size());
  ASSERT_TRUE(albedo.ok() && nd.ok() && orm.ok());
  struct MaterialPush {
    glm::mat4 world_to_clip;
    glm::vec4 view_dir, sphere;
    glm::ivec4 params, flags;
  };
  static_assert(sizeof(MaterialPush) == 128);
  const size_t count = static_cast<size_t>(kPixels) * kPixels;
  // Coverage (colour pass's >= 0.5, or the caster's) per pixel.
  auto render = [&](glm::vec3 direction, bool caster, glm::uvec4 fade) {
    std::vector<bool> covered;
    auto out = GpuBuffer::Create(*ctx_, count * 2 * sizeof(glm::vec4), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                 VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT, VK_MEMORY_PROPERTY_HOST_CACHED_BIT, "pixels");
    auto in = GpuBuffer::Create(*ctx_, sizeof(fade), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT, 0, "cross fade");
    EXPECT_TRUE(out.ok() && in.ok());
    if (!out.ok() || !in.ok()) return covered;
    std::memcpy(in->mapped(), &fade, sizeof(fade));
    EXPECT_TRUE(in->FlushHostWrites().ok());
    const FrameCamera cam = CameraForDirection(direction);
    MaterialPush push{FrameViewProjection(cam, atlas.sphere),
                      glm::vec4(cam.direction, 0.0f),
                      glm::vec4(atlas.sphere.center, atlas.sphere.radius),
                      {static_cast<int>(atlas.layout), atlas.frames, TileSize(atlas.resolution, GridSide(layout)), 0},
                      {caster ? 1 : 0, kPixels, layout.ring_views, 1}};
    const uint32_t groups = (kPixels + 7) / 8;
    const absl::Status s = RunKernel(
        *ctx_, impostor_material_view_comp, sizeof(impostor_material_view_comp),
        {{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, VK_NULL_HANDLE, albedo->view(), sampler},
         {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, VK_NULL_HANDLE, nd->view(), sampler},
         {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, VK_NULL_HANDLE, orm->view(), sampler},
         {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, out->buffer()},
         {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, in->buffer()}},
        &push, sizeof(push), groups, groups);
    EXPECT_TRUE(s.ok()) << s;
    EXPECT_TRUE(out->InvalidateForHostRead().ok());
    const glm::vec4* px = static_cast<const glm::vec4*>(out->mapped());
    for (size_t i = 0; i < count; ++i) covered.push_back(caster ? px[i * 2].w > 0.5f : px[i * 2].w >= 0.5f);
    return covered;
  };
  const glm::vec3 direction = glm::normalize(glm::vec3(0.4f, 0.8f, 0.35f));
  for (bool caster : {false, true}) {
    const std::vector<bool> whole = render(direction, caster, glm::uvec4(0));
    ASSERT_EQ(whole.size(), count);
    for (uint32_t seed : {5u, 12345u}) {
      for (float t : {0.0f, 0.3f, 0.8f, 1.0f}) {
        uint32_t t_bits;
        std::memcpy(&t_bits, &t, sizeof(t_bits));
        const std::vector<bool> faded = render(direction, caster, glm::uvec4(1u, t_bits, seed, 0u));
        ASSERT_EQ(faded.size(), count);
        int wrong = 0, kept = 0, object = 0;
        for (int y = 0; y < kPixels; ++y) {
          for (int x = 0; x < kPixels; ++x) {
            const size_t i = static_cast<size_t>(y) * kPixels + x;
            const bool want = whole[i] && sdk::CrossFadeDrawsImpostor(t, seed, x, y);
            wrong += faded[i] != want;
            kept += faded[i];
            object += whole[i];
          }
        }
        ASSERT_GT(object, 1000);
        EXPECT_EQ(wrong, 0) << (caster ? "shadow caster" : "colour pass") << " seed " << seed << " t " << t;
        EXPECT_NEAR(static_cast<double>(kept) / object, t, 0.05)
            << (caster ? "shadow caster" : "colour pass") << " seed " << seed << " t " << t;
      }
    }
  }
  vkDestroySampler(ctx_->device(), sampler, nullptr);
}

}  // namespace
}  // namespace impostor
