// The reference shader (shaders/impostor_runtime.glsl) against the C++: a
// compute shader evaluates impostorBlendFrames and the virtual-plane
// projection for thousands of directions on the Vulkan device (lavapipe
// suffices); every frame's weight must match BlendFrames within 1e-5 and its
// sample point ProjectToFrame within 1e-5, for every layout and both blend
// modes.
#include <cstdint>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <random>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "common/runtime/frame_blend.h"
#include "common/runtime/virtual_plane.h"
#include "common/runtime/reference_renderer.h"
#include "shaders/impostor_runtime_view_comp.h"
#include "shaders/impostor_runtime_weights_comp.h"
#include "tests/runtime/compute_kernel.h"
#include "tests/runtime/image_compare.h"
#include "tests/runtime/synthetic_atlas.h"
#include "worker/gpu/gpu_buffer.h"
#include "worker/gpu/vk_check.h"
#include "worker/gpu/vk_handle.h"
#include "worker/gpu/vulkan_context.h"

namespace impostor {
namespace {

using gpu::GpuBuffer;
using ::impostor::testing::KernelBinding;
using ::impostor::testing::RunKernel;
using ::impostor::testing::UploadImage;

struct Push {
  int32_t layout_kind, frames, mode, count, ring_views;
};

// The shader's IMPOSTOR_LAYOUT_* values are LayoutKind's order.
int32_t ShaderLayout(LayoutKind kind) { return static_cast<int32_t>(kind); }

bool IsRing(const ViewLayout& l) { return l.kind == LayoutKind::kRingTop || l.kind == LayoutKind::kBillboard; }

// Runs the weights shader; returns per direction 4 x (frame index, weight, s, t).
absl::StatusOr<std::vector<float>> RunShader(const gpu::VulkanContext& ctx, const std::vector<glm::vec4>& dirs,
                                             const ViewLayout& layout, BlendMode mode) {
  const VkMemoryPropertyFlags host = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT;
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(GpuBuffer in,
                                GpuBuffer::Create(ctx, dirs.size() * sizeof(glm::vec4),
                                                  VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, host, 0, "directions"));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(GpuBuffer out,
                                GpuBuffer::Create(ctx, dirs.size() * 16 * sizeof(float),
                                                  VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, host,
                                                  VK_MEMORY_PROPERTY_HOST_CACHED_BIT, "weights"));
  std::memcpy(in.mapped(), dirs.data(), dirs.size() * sizeof(glm::vec4));
  IMPOSTOR_GPU_RETURN_IF_ERROR(in.FlushHostWrites());
  const Push push{ShaderLayout(layout.kind), layout.frames, mode == BlendMode::kTriangle3 ? 0 : 1,
                  static_cast<int32_t>(dirs.size()), layout.ring_views};
  IMPOSTOR_GPU_RETURN_IF_ERROR(RunKernel(
      ctx, impostor_runtime_weights_comp, sizeof(impostor_runtime_weights_comp),
      {{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, in.buffer()}, {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, out.buffer()}}, &push,
      sizeof(push), static_cast<uint32_t>((dirs.size() + 63) / 64), 1));
  IMPOSTOR_GPU_RETURN_IF_ERROR(out.InvalidateForHostRead());
  std::vector<float> result(dirs.size() * 16);
  std::memcpy(result.data(), out.mapped(), result.size() * sizeof(float));
  return result;
}

std::vector<glm::vec4> TestDirections(const ViewLayout& layout) {
  std::vector<glm::vec4> dirs;
  std::mt19937 rng(11);
  std::normal_distribution<float> n(0.0f, 1.0f);
  for (int i = 0; i < 4000; ++i) {
    glm::vec3 d = glm::normalize(glm::vec3(n(rng), n(rng), n(rng)));
    dirs.emplace_back(d, 0.0f);
  }
  // Every frame's own direction.
  for (int i = 0; i < FrameCount(layout); ++i) dirs.emplace_back(FrameDirectionAt(layout, i), 0.0f);
  if (layout.kind == LayoutKind::kOctahedral || layout.kind == LayoutKind::kHemiOctahedral) {
    // Points on grid lines and diagonals, where tie-breaking decides.
    const int frames = layout.frames;
    const float n1 = static_cast<float>(frames - 1);
    for (int row = 0; row < frames; ++row) {
      for (int col = 0; col < frames; ++col) {
        for (glm::vec2 off : {glm::vec2(0.5f, 0.0f), glm::vec2(0.0f, 0.5f), glm::vec2(0.5f, 0.5f), glm::vec2(0.25f, 0.25f)}) {
          const glm::vec2 g = glm::vec2(col, row) + off;
          if (g.x > n1 || g.y > n1) continue;
          dirs.emplace_back(LayoutToDirection(layout.kind, g / n1 * 2.0f - 1.0f), 0.0f);
        }
      }
    }
  } else {
    // Half way between columns, on and between rows, in the pole caps and
    // below the horizon.
    const float pi = 3.14159265f;
    const int columns = IsRing(layout) ? (layout.kind == LayoutKind::kBillboard ? 8 : layout.ring_views) : layout.frames;
    for (int col = 0; col < columns; ++col) {
      for (float f : {0.0f, 0.25f, 0.5f}) {
        const float az = (static_cast<float>(col) + f) * 2.0f * pi / columns;
        for (float el : {-1.3f, -0.6f, -0.2f, 0.0f, 0.2f, 0.5f, 0.9f, 1.2f, 1.5f, 1.565f}) {
          dirs.emplace_back(AzimuthElevationToDirection(az, el), 0.0f);
        }
      }
    }
  }
  // Axes and poles.
  for (glm::vec3 d : {glm::vec3(0, 1, 0), glm::vec3(0, -1, 0), glm::vec3(1, 0, 0), glm::vec3(-1, 0, 0),
                      glm::vec3(0, 0, 1), glm::vec3(0, 0, -1)}) {
    dirs.emplace_back(d, 0.0f);
  }
  return dirs;
}

// Every layout at a few sizes.
std::vector<ViewLayout> TestLayouts() {
  std::vector<ViewLayout> layouts;
  for (LayoutKind kind : {LayoutKind::kOctahedral, LayoutKind::kHemiOctahedral}) {
    for (int frames : {2, 6, 8, 12, 16}) layouts.push_back({kind, frames, 0});
  }
  for (int frames : {3, 5, 11, 21}) layouts.push_back({LayoutKind::kAzimuthElevation, frames, 0});
  for (int k : {3, 8, 24, 64}) {
    ViewLayout l{LayoutKind::kRingTop, 0, k};
    l.frames = GridSide(l);
    layouts.push_back(l);
  }
  layouts.push_back({LayoutKind::kBillboard, 3, 8});
  return layouts;
}

TEST(GlslBlend, ShaderWeightsMatchTheCpp) {
  auto ctx = gpu::VulkanContext::Create("");
  // Fails, not skips, without a device (lavapipe is enough): `ctest -LE gpu` opts out.
  ASSERT_TRUE(ctx.ok()) << "no Vulkan device: " << ctx.status();
  float worst = 0.0f, worst_st = 0.0f;
  size_t compared = 0;
  std::map<LayoutKind, float> worst_by_layout;
  for (const ViewLayout& layout : TestLayouts()) {
    {
      const int frames = layout.frames;
      const std::vector<glm::vec4> dirs = TestDirections(layout);
      for (BlendMode mode : {BlendMode::kTriangle3, BlendMode::kBilinear4}) {
        auto got = RunShader(**ctx, dirs, layout, mode);
        ASSERT_TRUE(got.ok()) << got.status();
        for (size_t i = 0; i < dirs.size(); ++i) {
          std::map<int, float> cpp, glsl;
          const FrameBlend want = BlendFrames(layout, glm::vec3(dirs[i]), mode);
          for (int k = 0; k < want.count; ++k) cpp[want.entries[k].index] += want.entries[k].weight;
          const FrameCamera view = CameraForDirection(glm::vec3(dirs[i]));
          for (int k = 0; k < 4; ++k) {
            const float* slot = &(*got)[i * 16 + k * 4];
            if (slot[0] < 0.0f) continue;
            const int index = static_cast<int>(slot[0]);
            glsl[index] += slot[1];
            ASSERT_LT(index, FrameCount(layout));
            const FrameCamera frame = CameraForDirection(FrameDirectionAt(layout, index));
            const PlaneSample st = ProjectToFrame(view, frame, {0.3f, -0.2f});
            // Below a hemi-octahedron's horizon the blended frames are seen
            // edge-on and the hit runs off to infinity (ill-conditioned as
            // 1 / facing^2): compare only frames facing the view by > 0.05,
            // relative to |st| beyond the tile.
            const bool conditioned = glm::dot(view.direction, frame.direction) > 0.05f;
            const float st_diff = st.valid && conditioned ? glm::length(st.st - glm::vec2(slot[2], slot[3])) /
                                                                std::max(1.0f, glm::length(st.st))
                                                          : 0.0f;
            worst_st = std::max(worst_st, st_diff);
            ASSERT_LE(st_diff, 1e-5f) << "frame " << index << " frames " << frames << " direction " << dirs[i].x << "," << dirs[i].y
                                      << "," << dirs[i].z;
          }
          float diff = 0.0f;
          for (const auto& [f, w] : cpp) diff = std::max(diff, std::abs(w - (glsl.count(f) ? glsl[f] : 0.0f)));
          for (const auto& [f, w] : glsl) diff = std::max(diff, std::abs(w - (cpp.count(f) ? cpp[f] : 0.0f)));
          worst = std::max(worst, diff);
          worst_by_layout[layout.kind] = std::max(worst_by_layout[layout.kind], diff);
          ++compared;
          ASSERT_LE(diff, 1e-5f) << LayoutName(layout.kind) << " frames=" << frames << " ring_views="
                                 << layout.ring_views << " " << BlendModeName(mode)
                                 << " direction " << dirs[i].x << "," << dirs[i].y << "," << dirs[i].z;
        }
      }
    }
  }
  std::printf("[ figures  ] %zu blends compared on %s: largest weight difference %.3g, largest (s, t) "
              "difference %.3g\n", compared, (*ctx)->info().name.c_str(), worst, worst_st);
  for (const auto& [kind, w] : worst_by_layout) {
    std::printf("[ figures  ]   %s: largest weight difference %.3g\n", std::string(LayoutName(kind)).c_str(), w);
  }
}

struct ViewPush {
  glm::vec4 view_dir, view_up, view_right;
  glm::ivec4 params;  // layout, frames, tile_size, mode
  glm::ivec4 flags;   // reconstruction (IMPOSTOR_RECONSTRUCT_*), has_orm, pixels, ring_views
  glm::ivec4 placement{0};  // x: the view's first pixel in the output buffer
};

uint8_t Srgb8(float linear) {
  const float c = std::clamp(linear, 0.0f, 1.0f);
  const float s = c <= 0.0031308f ? c * 12.92f : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
  return static_cast<uint8_t>(std::lround(s * 255.0f));
}
uint8_t Unorm8(float v) { return static_cast<uint8_t>(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f)); }
uint16_t Unorm16(float v) { return static_cast<uint16_t>(std::lround(std::clamp(v, 0.0f, 1.0f) * 65535.0f)); }

// Renders a view with impostor_runtime_view.comp and encodes it as
// RenderImpostorView does (coverage iff alpha >= 0.5, bake encodings).
absl::StatusOr<ViewImages> RenderWithShader(const gpu::VulkanContext& ctx, const ImpostorAtlas& atlas,
                                            VkImageView albedo, VkImageView normal_depth, VkImageView orm,
                                            VkSampler sampler, const FrameCamera& view, int pixels,
                                            const ReferenceRenderOptions& options) {
  const size_t count = static_cast<size_t>(pixels) * pixels;
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(
      GpuBuffer out, GpuBuffer::Create(ctx, count * 3 * sizeof(glm::vec4), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                       VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT, VK_MEMORY_PROPERTY_HOST_CACHED_BIT,
                                       "view pixels"));
  ViewPush push;
  push.view_dir = glm::vec4(view.direction, 0.0f);
  push.view_up = glm::vec4(view.up, 0.0f);
  push.view_right = glm::vec4(view.right, 0.0f);
  const ViewLayout layout = AtlasViewLayout(atlas);
  push.params = {ShaderLayout(atlas.layout), atlas.frames, TileSize(atlas.resolution, GridSide(layout)),
                 options.blend == BlendMode::kTriangle3 ? 0 : 1};
  const int mode = options.reconstruction == Reconstruction::kDepth ? 2 : (options.parallax ? 1 : 0);
  push.flags = {mode, 1, pixels, layout.ring_views};
  const uint32_t groups = static_cast<uint32_t>((pixels + 7) / 8);
  IMPOSTOR_GPU_RETURN_IF_ERROR(RunKernel(ctx, impostor_runtime_view_comp, sizeof(impostor_runtime_view_comp),
                                         {{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, VK_NULL_HANDLE, albedo, sampler},
                                          {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, VK_NULL_HANDLE, normal_depth,
                                           sampler},
                                          {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, VK_NULL_HANDLE, orm, sampler},
                                          {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, out.buffer()}},
                                         &push, sizeof(push), groups, groups));
  IMPOSTOR_GPU_RETURN_IF_ERROR(out.InvalidateForHostRead());
  const glm::vec4* px = static_cast<const glm::vec4*>(out.mapped());
  ViewImages v;
  v.width = v.height = pixels;
  v.albedo_alpha.assign(count * 4, 0);
  v.orm.assign(count * 4, 0);
  v.normal_depth.resize(count * 4);
  for (size_t i = 0; i < count; ++i) {
    const glm::vec4 a = px[i * 3], nd = px[i * 3 + 1], o = px[i * 3 + 2];
    if (a.w < 0.5f) {
      v.normal_depth[i * 4] = v.normal_depth[i * 4 + 1] = v.normal_depth[i * 4 + 2] = kEmptyNormal16;
      v.normal_depth[i * 4 + 3] = kEmptyDepth16;
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      v.albedo_alpha[i * 4 + k] = Srgb8(a[k]);
      v.normal_depth[i * 4 + k] = Unorm16(nd[k] * 0.5f + 0.5f);
      v.orm[i * 4 + k] = Unorm8(o[k]);
    }
    v.albedo_alpha[i * 4 + 3] = 255;
    v.orm[i * 4 + 3] = 255;
    v.normal_depth[i * 4 + 3] = Unorm16(nd.w);
  }
  return v;
}

// The whole shading path of the shader (virtual planes, tile sampling,
// parallax march, blending, depth) against RenderImpostorView on the same
// synthetic atlas and views. Float rounding differs between the device and
// the CPU (e.g. fused multiply-adds), which moves sample points by ~1e-6 of
// a tile; where neighbouring texels differ a lot (a sphere's rim) that shows
// as up to ~1e-3 in a normal and ~2e-4 in depth, hence the tolerances.
// Where a pixel sits on a discrete choice's tie (a march step's hit test),
// that rounding can flip the choice and the pixel differs by a whole texel
// step: an NVIDIA H100 did so at one pixel of the 120 views (normal
// 3803/65535, depth 90/65535; lavapipe at none). So each view may have as
// many such pixels as it may have coverage mismatches, for the same reason.
TEST(GlslBlend, ShaderViewMatchesTheReferenceRenderer) {
  auto ctx = gpu::VulkanContext::Create("");
  // Fails, not skips, without a device (lavapipe is enough): `ctest -LE gpu` opts out.
  ASSERT_TRUE(ctx.ok()) << "no Vulkan device: " << ctx.status();
  const gpu::VulkanContext& c = **ctx;
  VkSamplerCreateInfo sampler_info{};
  sampler_info.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO;
  sampler_info.magFilter = sampler_info.minFilter = VK_FILTER_NEAREST;
  sampler_info.addressModeU = sampler_info.addressModeV = sampler_info.addressModeW =
      VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  VkSampler sampler_raw;
  ASSERT_EQ(vkCreateSampler(c.device(), &sampler_info, nullptr, &sampler_raw), VK_SUCCESS);
  gpu::UniqueSampler sampler(c.device(), sampler_raw);
  int mismatched = 0, total = 0, worst_albedo = 0, worst_normal = 0, worst_depth = 0;
  int normal_beyond = 0, depth_beyond = 0;
  const std::vector<ViewLayout> layouts = {{LayoutKind::kOctahedral, 8, 0},
                                           {LayoutKind::kHemiOctahedral, 8, 0},
                                           {LayoutKind::kAzimuthElevation, 7, 0},
                                           {LayoutKind::kRingTop, 4, 12},
                                           {LayoutKind::kBillboard, 3, 8}};
  for (const ViewLayout& layout : layouts) {
    // 64 px tiles, as the 64 px views: a view pixel half way between two
    // texels would sit exactly on the 0.5 coverage threshold at edges, where
    // the last bit of float rounding decides.
    const int size = 64 * GridSide(layout);
    const ImpostorAtlas atlas = ::impostor::testing::BakeSyntheticAtlas(layout, size);
    auto albedo = UploadImage(c, VK_FORMAT_R8G8B8A8_SRGB, size, size, atlas.albedo_alpha.data(),
                              atlas.albedo_alpha.size());
    auto normal_depth = UploadImage(c, VK_FORMAT_R16G16B16A16_UNORM, size, size, atlas.normal_depth.data(),
                                    atlas.normal_depth.size() * sizeof(uint16_t));
    auto orm = UploadImage(c, VK_FORMAT_R8G8B8A8_UNORM, size, size, atlas.orm.data(), atlas.orm.size());
    ASSERT_TRUE(albedo.ok() && normal_depth.ok() && orm.ok());
    for (glm::vec3 d : {glm::vec3(0.31f, 0.42f, 0.77f), glm::vec3(-0.6f, 0.1f, 0.3f), glm::vec3(0.2f, 0.9f, -0.4f),
                        FrameDirectionAt(layout, FrameCount(layout) / 2 + 1)}) {
      const FrameCamera view = ViewCameraFor(glm::normalize(d));
      for (BlendMode mode : {BlendMode::kTriangle3, BlendMode::kBilinear4}) {
        for (int variant = 0; variant < 3; ++variant) {  // plain flat, plain parallax, depth
          const bool parallax = variant == 1;
          const ReferenceRenderOptions options{mode, parallax,
                                               variant == 2 ? Reconstruction::kDepth : Reconstruction::kPlain};
          auto shader = RenderWithShader(c, atlas, albedo->view(), normal_depth->view(), orm->view(), sampler_raw,
                                         view, 64, options);
          ASSERT_TRUE(shader.ok()) << shader.status();
          const ViewImages cpp = RenderImpostorView(atlas, view, 64, options);
          const ::impostor::testing::Comparison cmp = ::impostor::testing::Compare(*shader, cpp);
          mismatched += cmp.coverage_mismatch;
          total += 64 * 64;
          worst_albedo = std::max(worst_albedo, cmp.albedo_max_diff);
          worst_normal = std::max(worst_normal, cmp.normal_max_diff);
          worst_depth = std::max(worst_depth, cmp.depth_max_diff);
          EXPECT_LE(cmp.coverage_mismatch, 2) << LayoutName(layout.kind) << " " << BlendModeName(mode) << " variant "
                                              << variant << " view " << view.direction.x << "," << view.direction.y << "," << view.direction.z;
          EXPECT_LE(cmp.albedo_max_diff, 1);
          EXPECT_LE(cmp.orm_max_diff, 1);
          // 0.005 in a normal component, 0.0006 of the sphere's diameter.
          const ::impostor::testing::PixelsBeyond beyond = ::impostor::testing::CountPixelsBeyond(*shader, cpp, 160, 40);
          normal_beyond += beyond.normal;
          depth_beyond += beyond.depth;
          EXPECT_LE(beyond.normal, 2) << LayoutName(layout.kind) << " " << BlendModeName(mode) << " variant " << variant
                                      << ": largest normal difference " << cmp.normal_max_diff << "/65535";
          EXPECT_LE(beyond.depth, 2) << LayoutName(layout.kind) << " " << BlendModeName(mode) << " variant " << variant
                                     << ": largest depth difference " << cmp.depth_max_diff << "/65535";
        }
      }
    }
  }
  std::printf("[ figures  ] shader vs C++ views: %d of %d pixels differ in coverage; largest differences: albedo "
              "%d/255, normal %d/65535, depth %d/65535; pixels beyond 160 in a normal: %d, beyond 40 in depth: %d\n",
              mismatched, total, worst_albedo, worst_normal, worst_depth, normal_beyond, depth_beyond);
}

}  // namespace
}  // namespace impostor
