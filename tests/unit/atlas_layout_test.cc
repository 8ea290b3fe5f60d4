#include "common/atlas/atlas_layout.h"

#include <cmath>
#include <string>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "common/atlas/frame_camera.h"

namespace impostor {
namespace {

struct LayoutCase {
  LayoutKind kind;
  int frames;
};

std::string CaseName(const testing::TestParamInfo<LayoutCase>& info) {
  std::string name(LayoutName(info.param.kind));
  for (char& c : name) if (c == '-') c = '_';
  return name + "_" + std::to_string(info.param.frames);
}

class LayoutRoundTrip : public testing::TestWithParam<LayoutCase> {};

TEST_P(LayoutRoundTrip, EveryFrameDecodesAndEncodesToItself) {
  const auto [kind, frames] = GetParam();
  for (int row = 0; row < frames; ++row) {
    for (int col = 0; col < frames; ++col) {
      const FrameCoord frame{col, row};
      const glm::vec3 d = FrameDirection(kind, frames, frame);
      EXPECT_NEAR(glm::length(d), 1.0f, 1e-5f);
      const FrameCoord back = EncodeFrame(kind, frames, d);
      EXPECT_EQ(back, CanonicalFrame(kind, frames, frame))
          << LayoutName(kind) << " " << frames << "x" << frames << " frame (" << col << "," << row
          << ") encoded to (" << back.col << "," << back.row << ")";
      // A duplicate frame shows exactly the view of its canonical frame.
      const glm::vec3 canonical_d = FrameDirection(kind, frames, back);
      EXPECT_LT(glm::length(canonical_d - d), 1e-5f) << "frame (" << col << "," << row << ")";
      if (kind == LayoutKind::kHemiOctahedral) {
        EXPECT_EQ(back, frame) << "hemi-octahedral frames are all distinct";
        EXPECT_GE(d.y, -1e-6f);
      }
    }
  }
}

TEST_P(LayoutRoundTrip, DirectionsNearAFrameEncodeToThatFrame) {
  const auto [kind, frames] = GetParam();
  // Nudge each interior frame's grid position by less than half a cell.
  for (int row = 1; row < frames - 1; ++row) {
    for (int col = 1; col < frames - 1; ++col) {
      for (glm::vec2 nudge : {glm::vec2(0.3f, 0.2f), glm::vec2(-0.45f, 0.4f), glm::vec2(0.1f, -0.49f)}) {
        const float scale = 2.0f / static_cast<float>(frames - 1);
        glm::vec2 oct = glm::vec2(col, row) * scale - 1.0f + nudge * scale;
        const glm::vec3 d = LayoutToDirection(kind, oct);
        EXPECT_EQ(EncodeFrame(kind, frames, d), (FrameCoord{col, row}))
            << LayoutName(kind) << " frame (" << col << "," << row << ") nudge " << nudge.x << "," << nudge.y;
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(All, LayoutRoundTrip,
                         testing::Values(LayoutCase{LayoutKind::kOctahedral, 2}, LayoutCase{LayoutKind::kOctahedral, 7},
                                         LayoutCase{LayoutKind::kOctahedral, 8}, LayoutCase{LayoutKind::kOctahedral, 12},
                                         LayoutCase{LayoutKind::kOctahedral, 31},
                                         LayoutCase{LayoutKind::kHemiOctahedral, 2},
                                         LayoutCase{LayoutKind::kHemiOctahedral, 7},
                                         LayoutCase{LayoutKind::kHemiOctahedral, 8},
                                         LayoutCase{LayoutKind::kHemiOctahedral, 12},
                                         LayoutCase{LayoutKind::kHemiOctahedral, 31}),
                         CaseName);

TEST(AtlasLayout, PolesAndHorizonLandWhereTheLayoutSays) {
  // Octahedral: +Y in the centre, -Y at the corners.
  EXPECT_EQ(EncodeFrame(LayoutKind::kOctahedral, 9, {0, 1, 0}), (FrameCoord{4, 4}));
  EXPECT_EQ(EncodeFrame(LayoutKind::kOctahedral, 9, {0, -1, 0}), (FrameCoord{0, 0}));
  // Hemi-octahedral: +Y in the centre, below-horizon directions clamp to it.
  EXPECT_EQ(EncodeFrame(LayoutKind::kHemiOctahedral, 9, {0, 1, 0}), (FrameCoord{4, 4}));
  const glm::vec3 below = glm::normalize(glm::vec3(1, -0.5f, 0));
  const glm::vec3 horizon = FrameDirection(LayoutKind::kHemiOctahedral, 9,
                                           EncodeFrame(LayoutKind::kHemiOctahedral, 9, below));
  EXPECT_NEAR(horizon.y, 0.0f, 1e-6f);
  EXPECT_GT(horizon.x, 0.9f);
}

TEST(AtlasLayout, BoundaryDirectionsRoundHalfUpEverywhere) {
  // Exactly half-way between frame columns 3 and 4 on the centre row.
  const int frames = 9;
  const float scale = 2.0f / (frames - 1);
  const glm::vec2 oct(3.5f * scale - 1.0f, 4.0f * scale - 1.0f);
  const glm::vec3 d = OctahedralToDirection(oct);
  EXPECT_EQ(EncodeFrame(LayoutKind::kOctahedral, frames, d).col, 4);
}

TEST(AtlasLayout, ParseLayoutNamesTheAcceptedValues) {
  EXPECT_EQ(*ParseLayout("octahedral"), LayoutKind::kOctahedral);
  EXPECT_EQ(*ParseLayout("hemi-octahedral"), LayoutKind::kHemiOctahedral);
  const auto bad = ParseLayout("cubemap");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(bad.status().message().find("hemi-octahedral"), std::string::npos);
}

TEST(FrameCamera, ViewProjectionMapsTheSphereOntoTheTileSquare) {
  const BoundingSphere sphere{{1.0f, 2.0f, 3.0f}, 2.0f};
  for (const FrameCamera& cam : AtlasCameras(LayoutKind::kOctahedral, 5, 500)) {
    const glm::mat4 m = FrameViewProjection(cam, sphere);
    // Nearest point of the sphere to the camera: depth 0; its centre: 0.5.
    const glm::vec4 near = m * glm::vec4(sphere.center + cam.direction * sphere.radius, 1.0f);
    EXPECT_NEAR(near.z, 0.0f, 1e-5f);
    const glm::vec4 centre = m * glm::vec4(sphere.center, 1.0f);
    EXPECT_NEAR(centre.x, 0.0f, 1e-5f);
    EXPECT_NEAR(centre.z, 0.5f, 1e-5f);
    // Camera up is the top of the tile (Vulkan clip y = -1).
    const glm::vec4 top = m * glm::vec4(sphere.center + cam.up * sphere.radius, 1.0f);
    EXPECT_NEAR(top.y, -1.0f, 1e-5f);
    const glm::vec4 right = m * glm::vec4(sphere.center + cam.right * sphere.radius, 1.0f);
    EXPECT_NEAR(right.x, 1.0f, 1e-5f);
    EXPECT_NEAR(glm::dot(cam.up, cam.direction), 0.0f, 1e-5f);
    EXPECT_EQ(cam.tile.width, 100);
    EXPECT_EQ(cam.tile.x, cam.frame.col * 100);
  }
}

}  // namespace
}  // namespace impostor
