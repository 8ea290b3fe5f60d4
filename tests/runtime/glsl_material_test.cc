// The reference material (shaders/impostor_material.glsl) on a Vulkan device
// (lavapipe suffices), against the ray-cast object it was baked from
// (tests/runtime/synthetic_atlas.h) standing on a ground plane that cuts
// through it, under one directional light:
//  - pixel depth offset: where the impostor crosses the ground, the visible
//    boundary (object in front of the ground or not) matches the object's
//    within 2 px at 512 px; a flat card without the offset does not;
//  - shadow caster: the shadow it casts on the ground covers the object's
//    shadow (IoU >= 0.9);
//  - lit (Lambert) impostor against the lit object: PSNR reported;
//  - cross-fade: the colour pass and the shadow caster keep exactly the
//    pixels CrossFadeDrawsImpostor (the C++ SDK) gives the impostor.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "common/atlas/frame_camera.h"
#include "common/runtime/reference_renderer.h"
#include "common/runtime/virtual_plane.h"
#include "shaders/impostor_material_view_comp.h"
#include "tests/support/boundary_mismatch.h"
#include "tests/runtime/compute_kernel.h"
#include "tests/runtime/synthetic_atlas.h"
#include "worker/gpu/gpu_buffer.h"
#include "worker/gpu/vk_handle.h"
#include "worker/gpu/vulkan_context.h"

namespace impostor {
namespace {

using gpu::GpuBuffer;
using ::impostor::testing::RunKernel;
using ::impostor::testing::UploadImage;

constexpr int kPixels = 512;
// The ground: the plane y = kGround in sphere space (radius units from the
// bounding sphere's centre); it cuts through both balls of the object.
constexpr float kGround = 0.05f;

struct MaterialPush {
  glm::mat4 world_to_clip;
  glm::vec4 view_dir, sphere;
  glm::ivec4 params, flags;
};
static_assert(sizeof(MaterialPush) == 128);

struct MaterialView {
  std::vector<glm::vec4> colour_coverage;  // per pixel
  std::vector<glm::vec4> normal_depth;     // world normal, frag depth
};

class GlslMaterialTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto ctx = gpu::VulkanContext::Create("");
    // Fails, not skips, without a device (lavapipe is enough): `ctest -LE gpu` opts out.
    ASSERT_TRUE(ctx.ok()) << "no Vulkan device: " << ctx.status();
    ctx_ = std::move(*ctx);
    VkSamplerCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO;
    info.magFilter = info.minFilter = VK_FILTER_NEAREST;
    info.addressModeU = info.addressModeV = info.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    ASSERT_EQ(vkCreateSampler(ctx_->device(), &info, nullptr, &sampler_), VK_SUCCESS);
  }
  void TearDown() override {
    if (ctx_ && sampler_ != VK_NULL_HANDLE) vkDestroySampler(ctx_->device(), sampler_, nullptr);
  }

  // One view (or, with `caster`, the light's depth-only view) through the
  // material; `cross_fade` as impostor_material_view.comp's buffer (x = 0:
  // no fade).
  MaterialView Render(const ImpostorAtlas& atlas, glm::vec3 direction, bool caster, bool parallax,
                      glm::uvec4 cross_fade = glm::uvec4(0)) {
    const int size = atlas.resolution;
    auto albedo = UploadImage(*ctx_, VK_FORMAT_R8G8B8A8_SRGB, size, size, atlas.albedo_alpha.data(),
                              atlas.albedo_alpha.size());
    auto nd = UploadImage(*ctx_, VK_FORMAT_R16G16B16A16_UNORM, size, size, atlas.normal_depth.data(),
                          atlas.normal_depth.size() * sizeof(uint16_t));
    auto orm = UploadImage(*ctx_, VK_FORMAT_R8G8B8A8_UNORM, size, size, atlas.orm.data(), atlas.orm.size());
    EXPECT_TRUE(albedo.ok() && nd.ok() && orm.ok());
    const size_t count = static_cast<size_t>(kPixels) * kPixels;
    auto out = GpuBuffer::Create(*ctx_, count * 2 * sizeof(glm::vec4), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                 VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT, VK_MEMORY_PROPERTY_HOST_CACHED_BIT, "pixels");
    EXPECT_TRUE(out.ok());
    auto fade = GpuBuffer::Create(*ctx_, sizeof(glm::uvec4), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                  VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT, VK_MEMORY_PROPERTY_HOST_CACHED_BIT, "cross fade");
    EXPECT_TRUE(fade.ok());
    std::memcpy(fade->mapped(), &cross_fade, sizeof(cross_fade));
    EXPECT_TRUE(fade->FlushHostWrites().ok());
    const FrameCamera cam = CameraForDirection(direction);
    const ViewLayout layout = AtlasViewLayout(atlas);
    MaterialPush push{FrameViewProjection(cam, atlas.sphere),
                      glm::vec4(cam.direction, 0.0f),
                      glm::vec4(atlas.sphere.center, atlas.sphere.radius),
                      {static_cast<int>(atlas.layout), atlas.frames, TileSize(atlas.resolution, GridSide(layout)), 0},
                      {caster ? 1 : 0, kPixels, layout.ring_views, parallax ? 1 : 0}};
    const uint32_t groups = (kPixels + 7) / 8;
    const absl::Status s = RunKernel(
        *ctx_, impostor_material_view_comp, sizeof(impostor_material_view_comp),
        {{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, VK_NULL_HANDLE, albedo->view(), sampler_},
         {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, VK_NULL_HANDLE, nd->view(), sampler_},
         {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, VK_NULL_HANDLE, orm->view(), sampler_},
         {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, out->buffer()},
         {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, fade->buffer()}},
        &push, sizeof(push), groups, groups);
    EXPECT_TRUE(s.ok()) << s;
    EXPECT_TRUE(out->InvalidateForHostRead().ok());
    const glm::vec4* px = static_cast<const glm::vec4*>(out->mapped());
    MaterialView v;
    for (size_t i = 0; i < count; ++i) {
      v.colour_coverage.push_back(px[i * 2]);
      v.normal_depth.push_back(px[i * 2 + 1]);
    }
    return v;
  }

  std::unique_ptr<gpu::VulkanContext> ctx_;
  VkSampler sampler_ = VK_NULL_HANDLE;
};

// Depth (0..1, the bake convention) of the ground under pixel (x, y) of the
// view toward `direction`, or 2 where the pixel's ray misses it.
float GroundDepth(const FrameCamera& cam, int x, int y) {
  const float s = (x + 0.5f) / kPixels * 2.0f - 1.0f, t = 1.0f - (y + 0.5f) / kPixels * 2.0f;
  const glm::vec3 o = s * cam.right + t * cam.up + cam.direction;  // sphere space, depth 0
  if (std::abs(cam.direction.y) < 1e-6f) return 2.0f;
  const float k = (o.y - kGround) / cam.direction.y;  // along -direction
  if (k < 0.0f) return 2.0f;
  return k * 0.5f;  // depth grows by 1/2 per radius travelled
}

TEST_F(GlslMaterialTest, DepthOffsetPutsTheGroundCrossingWhereTheObjectHasIt) {
  struct Case {
    const char* name;
    ViewLayout layout;
    int resolution;
    glm::vec3 direction;
    bool parallax;
    int allowed_far;  // pixels off by more than 2 px
  };
  const Case cases[] = {
      {"octahedral 12, frame view", {LayoutKind::kOctahedral, 12, 0}, 2048, {}, false, 0},
      {"azimuth-elevation 11, frame view", {LayoutKind::kAzimuthElevation, 11, 0}, 2048, {}, false, 0},
      {"billboard, frame view", {LayoutKind::kBillboard, 3, 8}, 1536, {}, false, 0},
      {"octahedral 12, between frames, parallax", {LayoutKind::kOctahedral, 12, 0}, 2048,
       glm::normalize(glm::vec3(0.55f, 0.45f, 0.7f)), true, -1},
  };
  for (const Case& c : cases) {
    const ImpostorAtlas atlas = ::impostor::testing::BakeSyntheticAtlas(c.layout, c.resolution);
    // The frame nearest to looking down at the ground from 30 degrees (the
    // billboard's only frame above the horizon is its top view).
    glm::vec3 dir = c.direction;
    if (glm::length(dir) == 0.0f) {
      float best = -1e9f;
      for (int i = 0; i < FrameCount(c.layout); ++i) {
        const glm::vec3 d = FrameDirectionAt(c.layout, i);
        const float score = -std::abs(d.y - 0.5f) + 0.01f * d.z;
        if (d.y > 0.2f && score > best) best = score, dir = d;
      }
    }
    const FrameCamera cam = CameraForDirection(dir);
    const MaterialView imp = Render(atlas, dir, /*caster=*/false, c.parallax);
    const ViewImages mesh = ::impostor::testing::RenderSyntheticView(cam, kPixels);
    const size_t count = static_cast<size_t>(kPixels) * kPixels;
    std::vector<uint8_t> mesh_front(count), imp_front(count), card_front(count), both(count);
    int crossing = 0;
    for (int y = 0; y < kPixels; ++y) {
      for (int x = 0; x < kPixels; ++x) {
        const size_t i = static_cast<size_t>(y) * kPixels + x;
        const float ground = GroundDepth(cam, x, y);
        const bool mesh_cov = mesh.albedo_alpha[i * 4 + 3] >= 128;
        const bool imp_cov = imp.colour_coverage[i].w >= 0.5f;
        both[i] = mesh_cov && imp_cov;
        mesh_front[i] = mesh_cov && mesh.normal_depth[i * 4 + 3] / 65535.0f < ground;
        imp_front[i] = imp_cov && imp.normal_depth[i].w < ground;
        card_front[i] = imp_cov && 0.5f < ground;  // a flat card through the centre, no depth offset
        crossing += both[i] && !mesh_front[i];
      }
    }
    const int far = testing::FarMismatches(imp_front, mesh_front, both, kPixels, 2);
    const int card_far = testing::FarMismatches(card_front, mesh_front, both, kPixels, 2);
    std::printf("[ figures  ] %s: %d object pixels behind the ground; boundary off by > 2 px at %d pixels with the "
                "depth offset, %d without\n",
                c.name, crossing, far, card_far);
    ASSERT_GT(crossing, 1000) << c.name << ": the ground must cut through the object";
    if (c.allowed_far >= 0) EXPECT_LE(far, c.allowed_far) << c.name;
    EXPECT_GT(card_far, 100) << c.name << ": without the offset the crossing must be wrong (the test can fail)";
  }
}

TEST_F(GlslMaterialTest, ShadowCasterCoversTheObjectsShadowAndLitPsnrIsReported) {
  const ViewLayout layout{LayoutKind::kOctahedral, 12, 0};
  const ImpostorAtlas atlas = ::impostor::testing::BakeSyntheticAtlas(layout, 2048);
  const glm::vec3 toward_light = glm::normalize(glm::vec3(0.4f, 0.8f, 0.35f));
  const FrameCamera light = CameraForDirection(toward_light);
  const MaterialView caster = Render(atlas, toward_light, /*caster=*/true, /*parallax=*/true);
  const ViewImages mesh = ::impostor::testing::RenderSyntheticView(light, kPixels);
  // In the light's view each pixel is one ground point: shadowed where the
  // caster is nearer the light than the ground.
  int inter = 0, uni = 0;
  for (int y = 0; y < kPixels; ++y) {
    for (int x = 0; x < kPixels; ++x) {
      const size_t i = static_cast<size_t>(y) * kPixels + x;
      const float ground = GroundDepth(light, x, y);
      if (ground > 1.5f) continue;
      const bool mesh_shadow = mesh.albedo_alpha[i * 4 + 3] >= 128 && mesh.normal_depth[i * 4 + 3] / 65535.0f < ground;
      const bool imp_shadow = caster.colour_coverage[i].w > 0.5f && caster.normal_depth[i].w < ground;
      inter += mesh_shadow && imp_shadow;
      uni += mesh_shadow || imp_shadow;
    }
  }
  ASSERT_GT(uni, 1000);
  const double iou = static_cast<double>(inter) / uni;
  std::printf("[ figures  ] shadow on the ground, impostor caster vs object: IoU %.4f\n", iou);
  EXPECT_GE(iou, 0.9);

  // Lit: Lambert + ambient from the material's albedo and world normal
  // against the object's, from a view between frames, over the object.
  const glm::vec3 view_dir = glm::normalize(glm::vec3(0.55f, 0.45f, 0.7f));
  const MaterialView imp = Render(atlas, view_dir, false, true);
  const ViewImages obj = ::impostor::testing::RenderSyntheticView(CameraForDirection(view_dir), kPixels);
  auto srgb_to_linear = [](uint8_t v) {
    const float c = v / 255.0f;
    return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
  };
  double se = 0;
  size_t n = 0;
  for (size_t i = 0; i < imp.colour_coverage.size(); ++i) {
    const bool a = obj.albedo_alpha[i * 4 + 3] >= 128, b = imp.colour_coverage[i].w >= 0.5f;
    if (!a && !b) continue;
    glm::vec3 lit_obj(0.0f), lit_imp(0.0f);
    if (a) {
      glm::vec3 n3, alb;
      for (int k = 0; k < 3; ++k) {
        n3[k] = obj.normal_depth[i * 4 + k] / 65535.0f * 2.0f - 1.0f;
        alb[k] = srgb_to_linear(obj.albedo_alpha[i * 4 + k]);
      }
      lit_obj = alb * (std::max(glm::dot(glm::normalize(n3), toward_light), 0.0f) + 0.2f);
    }
    if (b) {
      lit_imp = glm::vec3(imp.colour_coverage[i]) *
                (std::max(glm::dot(glm::vec3(imp.normal_depth[i]), toward_light), 0.0f) + 0.2f);
    }
    const glm::vec3 d = glm::clamp(lit_obj, 0.0f, 1.0f) - glm::clamp(lit_imp, 0.0f, 1.0f);
    se += glm::dot(d, d) / 3.0;
    ++n;
  }
  const double psnr = 10.0 * std::log10(1.0 / std::max(se / n, 1e-12));
  std::printf("[ figures  ] lit impostor vs lit object (Lambert, view between frames, parallax): PSNR %.2f dB over "
              "%zu pixels\n",
              psnr, n);
  RecordProperty("lit_psnr_db", std::to_string(psnr));
  EXPECT_GT(psnr, 20.0);
}

}  // namespace
}  // namespace impostor
