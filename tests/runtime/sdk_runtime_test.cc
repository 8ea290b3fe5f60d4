// The SDK header (client/include/impostor/runtime.h) against the common
// runtime it wraps: same frames, weights and sample points.
#include "impostor/runtime.h"  // first: the public header must stand alone

#include <random>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "common/runtime/frame_blend.h"
#include "common/runtime/virtual_plane.h"

namespace impostor {
namespace {

TEST(SdkRuntime, NamesMatchTheManifest) {
  EXPECT_EQ(sdk::LayoutFromName("octahedral"), sdk::Layout::kOctahedral);
  EXPECT_EQ(sdk::LayoutFromName("hemi-octahedral"), sdk::Layout::kHemiOctahedral);
  EXPECT_EQ(sdk::LayoutFromName("cube"), std::nullopt);
  EXPECT_EQ(sdk::LayoutName(sdk::Layout::kHemiOctahedral), "hemi-octahedral");
  EXPECT_EQ(sdk::BlendModeFromName("bilinear4"), sdk::BlendMode::kBilinear4);
  EXPECT_EQ(sdk::BlendModeFromName("triangle3"), sdk::BlendMode::kTriangle3);
  EXPECT_EQ(sdk::BlendModeFromName("nearest"), std::nullopt);
  EXPECT_EQ(sdk::BlendModeName(sdk::BlendMode::kTriangle3), "triangle3");
}

TEST(SdkRuntime, BlendFramesIsTheCommonImplementation) {
  std::mt19937 rng(3);
  std::normal_distribution<float> n(0.0f, 1.0f);
  for (int i = 0; i < 2000; ++i) {
    const float dir[3] = {n(rng), n(rng), n(rng)};
    for (sdk::Layout layout : {sdk::Layout::kOctahedral, sdk::Layout::kHemiOctahedral}) {
      for (sdk::BlendMode mode : {sdk::BlendMode::kTriangle3, sdk::BlendMode::kBilinear4}) {
        const sdk::FrameBlend got = sdk::BlendFrames(layout, 12, dir, mode);
        const FrameBlend want = BlendFrames(
            layout == sdk::Layout::kOctahedral ? LayoutKind::kOctahedral : LayoutKind::kHemiOctahedral, 12,
            glm::vec3(dir[0], dir[1], dir[2]),
            mode == sdk::BlendMode::kTriangle3 ? BlendMode::kTriangle3 : BlendMode::kBilinear4);
        ASSERT_EQ(got.count, want.count);
        for (int k = 0; k < got.count; ++k) {
          EXPECT_EQ(got.entries[k].frame, want.entries[k].index);
          EXPECT_EQ(got.entries[k].weight, want.entries[k].weight);
        }
      }
    }
  }
}

// A perspective ray through a point of a frame's plane lands where that
// frame's bake camera put the point; the frame's own orthographic ray hits
// the tile where the manifest says.
TEST(SdkRuntime, VirtualPlaneUvFollowsTheBakeCamera) {
  const float center[3] = {1.0f, 2.0f, 3.0f};
  const float radius = 2.0f;
  const int frames = 8, frame = FrameIndex(8, {5, 2});
  const sdk::FrameBasis basis = sdk::FrameCameraBasis(sdk::Layout::kOctahedral, frames, frame);
  const glm::vec3 d(basis.direction[0], basis.direction[1], basis.direction[2]);
  const glm::vec3 up(basis.up[0], basis.up[1], basis.up[2]);
  const glm::vec3 right(basis.right[0], basis.right[1], basis.right[2]);
  EXPECT_NEAR(glm::length(d - FrameDirection(LayoutKind::kOctahedral, frames, {5, 2})), 0.0f, 1e-6f);
  // The plane point at s = 0.4, t = -0.2 (radius units) -> u = 0.7, v = 0.6.
  const glm::vec3 c(center[0], center[1], center[2]);
  const glm::vec3 point = c + radius * (0.4f * right - 0.2f * up);
  const glm::vec3 eye = c + radius * 3.0f * glm::normalize(d + glm::vec3(0.1f, 0.2f, -0.1f));
  const glm::vec3 ray = point - eye;
  const float o[3] = {eye.x, eye.y, eye.z};
  const float r[3] = {ray.x, ray.y, ray.z};
  const sdk::FrameUv uv = sdk::VirtualPlaneUv(sdk::Layout::kOctahedral, frames, frame, center, radius, o, r);
  ASSERT_TRUE(uv.valid);
  EXPECT_NEAR(uv.u, 0.7f, 1e-5f);
  EXPECT_NEAR(uv.v, 0.6f, 1e-5f);
  float atlas_uv[2];
  sdk::FrameUvToAtlasUv(frames, 512, frame, uv, atlas_uv);  // tiles of 64 px
  EXPECT_NEAR(atlas_uv[0], (5 * 64 + 0.7f * 64) / 512.0f, 1e-6f);
  EXPECT_NEAR(atlas_uv[1], (2 * 64 + 0.6f * 64) / 512.0f, 1e-6f);
  // Looking from behind the frame: no sample.
  const float back[3] = {-r[0], -r[1], -r[2]};
  EXPECT_FALSE(sdk::VirtualPlaneUv(sdk::Layout::kOctahedral, frames, frame, center, radius, o, back).valid);
}

// Parallax over a flat depth of 0.3 (height 0.4): the march lands near where
// the ray meets that surface, and nowhere when the frame is empty.
TEST(SdkRuntime, ParallaxMarchesTheCapturedDepth) {
  const float center[3] = {0.0f, 0.0f, 0.0f};
  const int frames = 6, frame = FrameIndex(6, {2, 3});
  const sdk::FrameBasis basis = sdk::FrameCameraBasis(sdk::Layout::kHemiOctahedral, frames, frame);
  const glm::vec3 d(basis.direction[0], basis.direction[1], basis.direction[2]);
  const glm::vec3 toward_eye = glm::normalize(d + glm::vec3(0.15f, 0.0f, 0.1f));
  const glm::vec3 eye = 4.0f * toward_eye;
  const float o[3] = {eye.x, eye.y, eye.z};
  const float r[3] = {-toward_eye.x, -toward_eye.y, -toward_eye.z};
  const sdk::FrameUv flat =
      sdk::VirtualPlaneUv(sdk::Layout::kHemiOctahedral, frames, frame, center, 1.0f, o, r, 0.4f);
  const sdk::FrameUv marched = sdk::VirtualPlaneUvParallax(
      sdk::Layout::kHemiOctahedral, frames, frame, center, 1.0f, o, r, [](float, float, float* depth) {
        *depth = 0.3f;
        return true;
      });
  ASSERT_TRUE(marched.valid);
  EXPECT_NEAR(marched.u, flat.u, 0.01f);
  EXPECT_NEAR(marched.v, flat.v, 0.01f);
  EXPECT_FALSE(sdk::VirtualPlaneUvParallax(sdk::Layout::kHemiOctahedral, frames, frame, center, 1.0f, o, r,
                                           [](float, float, float*) { return false; })
                   .valid);
}

TEST(SdkRuntime, NewLayoutNamesAndManifestDescriptions) {
  EXPECT_EQ(sdk::LayoutFromName("azimuth-elevation"), sdk::Layout::kAzimuthElevation);
  EXPECT_EQ(sdk::LayoutFromName("ring-top"), sdk::Layout::kRingTop);
  EXPECT_EQ(sdk::LayoutFromName("billboard"), sdk::Layout::kBillboard);
  EXPECT_EQ(sdk::LayoutName(sdk::Layout::kRingTop), "ring-top");
  // Ring-top: K = views - 1, the grid side from K.
  auto ring = sdk::AtlasLayoutFromManifest("ring-top", 5, 25);
  ASSERT_TRUE(ring.has_value());
  EXPECT_EQ(ring->layout, sdk::Layout::kRingTop);
  EXPECT_EQ(ring->ring_views, 24);
  EXPECT_EQ(ring->frames, 5);
  EXPECT_EQ(sdk::FrameCount(*ring), 25);
  auto billboard = sdk::AtlasLayoutFromManifest("billboard", 3, 9);
  ASSERT_TRUE(billboard.has_value());
  EXPECT_EQ(billboard->ring_views, 8);
  auto ae = sdk::AtlasLayoutFromManifest("azimuth-elevation", 11, 121);
  ASSERT_TRUE(ae.has_value());
  EXPECT_EQ(ae->frames, 11);
  EXPECT_EQ(sdk::FrameCount(*ae), 121);
  // Counts that do not fit the layout, and unknown names.
  EXPECT_FALSE(sdk::AtlasLayoutFromManifest("billboard", 3, 8).has_value());
  EXPECT_FALSE(sdk::AtlasLayoutFromManifest("azimuth-elevation", 11, 120).has_value());
  EXPECT_FALSE(sdk::AtlasLayoutFromManifest("ring-top", 1, 1).has_value());
  EXPECT_FALSE(sdk::AtlasLayoutFromManifest("cube", 4, 16).has_value());
  // Layouts no bake produces: a ring of 99 (3..64), a ring whose grid side
  // is not `frames`, an even azimuth-elevation grid, 1 or 65 frames.
  EXPECT_FALSE(sdk::AtlasLayoutFromManifest("ring-top", 10, 100).has_value());
  EXPECT_FALSE(sdk::AtlasLayoutFromManifest("ring-top", 3, 25).has_value());
  EXPECT_FALSE(sdk::AtlasLayoutFromManifest("ring-top", 2, 3).has_value()) << "a ring of 2";
  EXPECT_FALSE(sdk::AtlasLayoutFromManifest("azimuth-elevation", 4, 16).has_value());
  EXPECT_FALSE(sdk::AtlasLayoutFromManifest("octahedral", 1, 1).has_value());
  EXPECT_FALSE(sdk::AtlasLayoutFromManifest("hemi-octahedral", 65, 65 * 65).has_value());
  EXPECT_FALSE(sdk::AtlasLayoutFromManifest("billboard", 4, 9).has_value());
  EXPECT_TRUE(sdk::AtlasLayoutFromManifest("ring-top", 2, 4).has_value()) << "a ring of 3";
  EXPECT_TRUE(sdk::AtlasLayoutFromManifest("ring-top", 9, 65).has_value()) << "a ring of 64";
}

// The (Layout, frames) overloads cannot describe ring-top (its ring count is
// not `frames`), and an AtlasLayout can be filled in by hand: such layouts
// get empty answers, never a plausible-looking frame 0.
TEST(SdkRuntime, LayoutsNoBakeProducesGetEmptyAnswers) {
  const float dir[3] = {1.0f, 0.2f, 0.3f};
  const float center[3] = {0.0f, 0.0f, 0.0f};
  const float eye[3] = {3.0f, 0.0f, 0.0f};
  const float ray[3] = {-1.0f, 0.0f, 0.0f};
  EXPECT_EQ(sdk::BlendFrames(sdk::Layout::kRingTop, 3, dir, sdk::BlendMode::kTriangle3).count, 0);
  EXPECT_FALSE(sdk::VirtualPlaneUv(sdk::Layout::kRingTop, 3, 0, center, 1.0f, eye, ray).valid);
  const sdk::FrameBasis basis = sdk::FrameCameraBasis(sdk::Layout::kRingTop, 3, 0);
  EXPECT_EQ(basis.direction[0] * basis.direction[0] + basis.direction[1] * basis.direction[1] +
                basis.direction[2] * basis.direction[2],
            0.0f);
  for (const sdk::AtlasLayout& bad : {sdk::AtlasLayout{sdk::Layout::kRingTop, 3, 99},
                                      sdk::AtlasLayout{sdk::Layout::kRingTop, 4, 8},
                                      sdk::AtlasLayout{sdk::Layout::kAzimuthElevation, 4, 0},
                                      sdk::AtlasLayout{sdk::Layout::kOctahedral, 0, 0},
                                      sdk::AtlasLayout{sdk::Layout::kBillboard, 3, 5}}) {
    EXPECT_EQ(sdk::BlendFrames(bad, dir, sdk::BlendMode::kBilinear4).count, 0) << sdk::LayoutName(bad.layout);
    const sdk::FrameBlend one{1, {{0, 1.0f}}};
    const sdk::DepthReconstruction depth = sdk::ReconstructDepth(
        bad, one, center, 1.0f, eye, ray, [](int, float, float, float* d) { *d = 0.5f; return 1.0f; });
    EXPECT_EQ(depth.coverage, 0.0f) << sdk::LayoutName(bad.layout);
  }
  // The same ring-top through a manifest's description works, and a frame
  // index outside the layout is refused too.
  const auto ring = sdk::AtlasLayoutFromManifest("ring-top", 3, 9);
  ASSERT_TRUE(ring.has_value());
  EXPECT_EQ(sdk::BlendFrames(*ring, dir, sdk::BlendMode::kTriangle3).count, 3);
  const float above[3] = {0.0f, 3.0f, 0.0f};
  const float down[3] = {0.0f, -1.0f, 0.0f};
  EXPECT_TRUE(sdk::VirtualPlaneUv(*ring, 8, center, 1.0f, above, down).valid) << "the top frame";
  EXPECT_FALSE(sdk::VirtualPlaneUv(*ring, 9, center, 1.0f, above, down).valid);
  EXPECT_FALSE(sdk::VirtualPlaneUv(*ring, -1, center, 1.0f, above, down).valid);
}

TEST(SdkRuntime, NewLayoutsAreTheCommonImplementation) {
  struct Pair {
    sdk::AtlasLayout sdk;
    ViewLayout common;
  };
  const std::vector<Pair> pairs = {
      {{sdk::Layout::kAzimuthElevation, 11, 0}, {LayoutKind::kAzimuthElevation, 11, 0}},
      {{sdk::Layout::kRingTop, 5, 24}, {LayoutKind::kRingTop, 5, 24}},
      {{sdk::Layout::kBillboard, 3, 8}, {LayoutKind::kBillboard, 3, 8}}};
  std::mt19937 rng(9);
  std::normal_distribution<float> n(0.0f, 1.0f);
  for (const Pair& p : pairs) {
    for (int i = 0; i < 1000; ++i) {
      const float dir[3] = {n(rng), n(rng), n(rng)};
      for (sdk::BlendMode mode : {sdk::BlendMode::kTriangle3, sdk::BlendMode::kBilinear4}) {
        const sdk::FrameBlend got = sdk::BlendFrames(p.sdk, dir, mode);
        const FrameBlend want = BlendFrames(p.common, glm::vec3(dir[0], dir[1], dir[2]),
                                            mode == sdk::BlendMode::kTriangle3 ? BlendMode::kTriangle3
                                                                               : BlendMode::kBilinear4);
        ASSERT_EQ(got.count, want.count);
        for (int k = 0; k < got.count; ++k) {
          EXPECT_EQ(got.entries[k].frame, want.entries[k].index);
          EXPECT_EQ(got.entries[k].weight, want.entries[k].weight);
        }
      }
    }
    // Frame cameras are the baker's, tiles in the layout's grid.
    for (int frame = 0; frame < FrameCount(p.common); ++frame) {
      const sdk::FrameBasis basis = sdk::FrameCameraBasis(p.sdk, frame);
      const glm::vec3 d = FrameDirectionAt(p.common, frame);
      EXPECT_NEAR(glm::length(glm::vec3(basis.direction[0], basis.direction[1], basis.direction[2]) - d), 0.0f,
                  1e-6f);
      const int resolution = 64 * GridSide(p.common);
      float atlas_uv[2];
      sdk::FrameUvToAtlasUv(p.sdk, resolution, frame, sdk::FrameUv{true, 0.5f, 0.25f}, atlas_uv);
      const FrameCoord tile = FrameTile(p.common, frame);
      EXPECT_NEAR(atlas_uv[0], (tile.col * 64 + 32) / static_cast<float>(resolution), 1e-6f);
      EXPECT_NEAR(atlas_uv[1], (tile.row * 64 + 16) / static_cast<float>(resolution), 1e-6f);
    }
  }
  // The top frame of ring-top: its own orthographic ray hits its tile's centre.
  const float center[3] = {0.0f, 0.0f, 0.0f};
  const float eye[3] = {0.0f, 3.0f, 0.0f};
  const float ray[3] = {0.0f, -1.0f, 0.0f};
  const sdk::FrameUv top = sdk::VirtualPlaneUv(pairs[1].sdk, 24, center, 1.0f, eye, ray);
  ASSERT_TRUE(top.valid);
  EXPECT_NEAR(top.u, 0.5f, 1e-6f);
  EXPECT_NEAR(top.v, 0.5f, 1e-6f);
}

}  // namespace
}  // namespace impostor

#include "common/runtime/reference_renderer.h"
#include "tests/runtime/synthetic_atlas.h"

namespace impostor {
namespace {

// Bilinear coverage and alpha-weighted depth of a tile at (u, v), clamped to
// the tile, as a shader reads it (the reference renderer's filter).
float ReadSurface(const ImpostorAtlas& atlas, const TileRect& tile, float u, float v, float* depth01) {
  if (!(u >= 0.0f && u <= 1.0f && v >= 0.0f && v <= 1.0f)) return 0.0f;
  const float fx = u * static_cast<float>(tile.width) - 0.5f;
  const float fy = v * static_cast<float>(tile.height) - 0.5f;
  const float flx = std::floor(fx), fly = std::floor(fy);
  const float ax = fx - flx, ay = fy - fly;
  const float bilinear[4] = {(1 - ax) * (1 - ay), ax * (1 - ay), (1 - ax) * ay, ax * ay};
  float covered = 0.0f, depth = 0.0f;
  for (int k = 0; k < 4; ++k) {
    const int tx = tile.x + std::clamp(static_cast<int>(flx) + (k & 1), 0, tile.width - 1);
    const int ty = tile.y + std::clamp(static_cast<int>(fly) + (k >> 1), 0, tile.height - 1);
    const size_t texel = (static_cast<size_t>(ty) * atlas.width + tx) * 4;
    const float w = bilinear[k] * atlas.albedo_alpha[texel + 3] / 255.0f;
    covered += w;
    depth += w * atlas.normal_depth[texel + 3] / 65535.0f;
  }
  if (covered > 0.0f) *depth01 = depth / covered;
  return covered;
}

// The SDK's depth mode on a synthetic atlas: on a frame's own direction it
// is that frame (weight 1, uv = the pixel's); between frames its coverage is
// the reference renderer's pixel for pixel, its weights sum to 1 and some
// frames drop out where they did not see the point (the ball behind).
TEST(SdkRuntime, ReconstructDepthMatchesTheReferenceRenderer) {
  const ViewLayout layout{LayoutKind::kOctahedral, 6, 0};
  const ImpostorAtlas atlas = ::impostor::testing::BakeSyntheticAtlas(layout, 384);
  const sdk::AtlasLayout sdk_layout{sdk::Layout::kOctahedral, 6, 0};
  const float center[3] = {0.0f, 0.0f, 0.0f};
  const int pixels = 64;
  int dropped = 0, checked = 0;
  for (const glm::vec3& d : {FrameDirectionAt(layout, 14),
                             glm::normalize(FrameDirectionAt(layout, 14) + FrameDirectionAt(layout, 15)),
                             glm::normalize(glm::vec3(0.31f, 0.42f, 0.77f))}) {
    const FrameCamera view = ViewCameraFor(d);
    const ViewImages want = RenderImpostorView(atlas, view, pixels, {BlendMode::kTriangle3, false, Reconstruction::kDepth});
    const float dir[3] = {d.x, d.y, d.z};
    const sdk::FrameBlend blend = sdk::BlendFrames(sdk_layout, dir, sdk::BlendMode::kTriangle3);
    int own = -1;  // the entry with all the weight, on a frame's own direction
    for (int k = 0; k < blend.count; ++k) {
      if (blend.entries[k].weight == 1.0f) own = k;
    }
    const float ray[3] = {-d.x, -d.y, -d.z};
    for (int y = 0; y < pixels; ++y) {
      for (int x = 0; x < pixels; ++x) {
        const glm::vec2 st((x + 0.5f) / pixels * 2.0f - 1.0f, 1.0f - (y + 0.5f) / pixels * 2.0f);
        const glm::vec3 o = ViewRayOrigin(view, st);
        const float origin[3] = {o.x, o.y, o.z};
        const sdk::DepthReconstruction r = sdk::ReconstructDepth(
            sdk_layout, blend, center, 1.0f, origin, ray, [&](int entry, float u, float v, float* depth01) {
              return ReadSurface(atlas, atlas.cameras[blend.entries[entry].frame].tile, u, v, depth01);
            });
        const bool covered = want.albedo_alpha[(static_cast<size_t>(y) * pixels + x) * 4 + 3] == 255;
        ASSERT_EQ(r.coverage >= 0.5f, covered) << "pixel " << x << "," << y;
        if (!covered) continue;
        ++checked;
        float total = 0.0f;
        for (int k = 0; k < blend.count; ++k) {
          total += r.weight[k];
          if (blend.entries[k].weight > 0.0f && r.weight[k] == 0.0f) ++dropped;
        }
        EXPECT_NEAR(total, 1.0f, 1e-5f);
        if (own >= 0) {
          EXPECT_EQ(r.weight[own], 1.0f);
          EXPECT_NEAR(r.uv[own].u, (x + 0.5f) / pixels, 1e-5f);
          EXPECT_NEAR(r.uv[own].v, (y + 0.5f) / pixels, 1e-5f);
        }
      }
    }
  }
  EXPECT_GT(checked, 3000);
  EXPECT_GT(dropped, 0) << "some frames must drop out where they did not see the point";
  EXPECT_EQ(sdk::ReconstructionFromName("depth"), sdk::Reconstruction::kDepth);
  EXPECT_EQ(sdk::ReconstructionFromName("plain"), sdk::Reconstruction::kPlain);
  EXPECT_EQ(sdk::ReconstructionFromName("relief"), std::nullopt);
  EXPECT_EQ(sdk::ReconstructionName(sdk::Reconstruction::kDepth), "depth");
  // Bad input: no radius, no ray.
  const float origin[3] = {0.0f, 0.0f, 2.0f}, zero[3] = {0.0f, 0.0f, 0.0f};
  const sdk::FrameBlend blend = sdk::BlendFrames(sdk_layout, origin, sdk::BlendMode::kTriangle3);
  auto never = [](int, float, float, float*) { return 1.0f; };
  EXPECT_EQ(sdk::ReconstructDepth(sdk_layout, blend, center, 0.0f, origin, zero, never).coverage, 0.0f);
  EXPECT_EQ(sdk::ReconstructDepth(sdk_layout, blend, center, 1.0f, origin, zero, never).coverage, 0.0f);
}

}  // namespace
}  // namespace impostor
