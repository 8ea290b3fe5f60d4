// The five view layouts through the one mapping (common/atlas/atlas_layout.h):
// every frame decodes and encodes to itself, the frame picked for a
// direction is the nearest baked one, and boundary directions land on the
// documented side.
#include <cmath>
#include <numbers>
#include <random>
#include <string>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "common/atlas/atlas_layout.h"
#include "common/atlas/frame_camera.h"

namespace impostor {
namespace {

struct Case {
  const char* name;
  ViewLayout layout;
};

const Case kCases[] = {
    {"octahedral_8", {LayoutKind::kOctahedral, 8, 0}},
    {"hemi_octahedral_9", {LayoutKind::kHemiOctahedral, 9, 0}},
    {"azimuth_elevation_3", {LayoutKind::kAzimuthElevation, 3, 0}},
    {"azimuth_elevation_5", {LayoutKind::kAzimuthElevation, 5, 0}},
    {"azimuth_elevation_11", {LayoutKind::kAzimuthElevation, 11, 0}},
    {"ring_top_3", {LayoutKind::kRingTop, 0, 3}},
    {"ring_top_10", {LayoutKind::kRingTop, 0, 10}},
    {"ring_top_24", {LayoutKind::kRingTop, 0, 24}},
    {"billboard", {LayoutKind::kBillboard, 0, kBillboardRingViews}},
};

class ViewLayoutTest : public testing::TestWithParam<Case> {};

float AngleDeg(glm::vec3 a, glm::vec3 b) {
  return std::acos(std::clamp(glm::dot(glm::normalize(a), glm::normalize(b)), -1.0f, 1.0f)) * 180.0f /
         std::numbers::pi_v<float>;
}

TEST_P(ViewLayoutTest, EveryFrameDecodesThenEncodesToItself) {
  const ViewLayout& layout = GetParam().layout;
  for (int i = 0; i < FrameCount(layout); ++i) {
    const glm::vec3 d = FrameDirectionAt(layout, i);
    EXPECT_NEAR(glm::length(d), 1.0f, 1e-5f) << "frame " << i;
    EXPECT_EQ(NearestFrame(layout, d), CanonicalFrameIndex(layout, i)) << "frame " << i;
  }
}

TEST_P(ViewLayoutTest, PickedFrameIsTheNearestBakedDirection) {
  const ViewLayout& layout = GetParam().layout;
  // On the octahedron's folded border a cell's nearest vertex can sit in the
  // mirrored cell across the fold, a hair nearer than the cell's own.
  const float tolerance = layout.kind == LayoutKind::kOctahedral ? 0.05f : 1e-3f;
  std::mt19937 rng(7);
  std::normal_distribution<float> gauss;
  for (int n = 0; n < 20000; ++n) {
    glm::vec3 d(gauss(rng), gauss(rng), gauss(rng));
    if (glm::length(d) < 1e-3f) continue;
    d = glm::normalize(d);
    if (layout.kind == LayoutKind::kHemiOctahedral) d.y = std::abs(d.y);
    float best = 1e9f;
    for (int i = 0; i < FrameCount(layout); ++i) best = std::min(best, AngleDeg(d, FrameDirectionAt(layout, i)));
    const float picked = AngleDeg(d, FrameDirectionAt(layout, NearestFrame(layout, d)));
    ASSERT_LE(picked, best + tolerance) << GetParam().name << " direction " << d.x << "," << d.y << "," << d.z;
  }
}

TEST_P(ViewLayoutTest, TilesFillTheGridWithoutOverlap) {
  const ViewLayout& layout = GetParam().layout;
  const int side = GridSide(layout);
  ASSERT_GE(side * side, FrameCount(layout));
  const std::vector<FrameCamera> cameras = AtlasCameras(layout, side * 32);
  ASSERT_EQ(static_cast<int>(cameras.size()), FrameCount(layout));
  std::vector<int> used(static_cast<size_t>(side * side), 0);
  for (const FrameCamera& c : cameras) {
    EXPECT_EQ(c.tile.width, 32);
    EXPECT_EQ(c.tile.x, c.frame.col * 32);
    EXPECT_EQ(c.tile.y, c.frame.row * 32);
    EXPECT_LT(glm::length(c.direction - FrameDirectionAt(layout, c.index)), 1e-6f);
    EXPECT_NEAR(glm::dot(c.up, c.direction), 0.0f, 1e-5f);
    ++used[static_cast<size_t>(c.frame.row * side + c.frame.col)];
  }
  for (int u : used) EXPECT_LE(u, 1);
}

INSTANTIATE_TEST_SUITE_P(AllLayouts, ViewLayoutTest, testing::ValuesIn(kCases),
                         [](const testing::TestParamInfo<Case>& info) { return std::string(info.param.name); });

TEST(AzimuthElevation, OddRowCountPutsTheMiddleRowOnTheHorizon) {
  for (int n : {3, 5, 7, 11, 63}) {
    const ViewLayout layout{LayoutKind::kAzimuthElevation, n, 0};
    for (int col = 0; col < n; ++col) {
      EXPECT_NEAR(FrameDirectionAt(layout, FrameIndex(n, {col, n / 2})).y, 0.0f, 1e-6f) << n << " col " << col;
    }
  }
  // The seed's 5 x 5: rows at 72, 36, 0, -36, -72 degrees, column 0 from +Z.
  const ViewLayout five{LayoutKind::kAzimuthElevation, 5, 0};
  const float expected[] = {72, 36, 0, -36, -72};
  for (int row = 0; row < 5; ++row) {
    const glm::vec3 d = FrameDirectionAt(five, FrameIndex(5, {0, row}));
    EXPECT_NEAR(std::asin(d.y) * 180.0f / std::numbers::pi_v<float>, expected[row], 1e-3f) << "row " << row;
    EXPECT_NEAR(d.x, 0.0f, 1e-6f);
    EXPECT_GT(d.z, 0.0f);
  }
  // Column 1 is 72 degrees of azimuth toward +X: az = atan2(x, z).
  const glm::vec2 ae = DirectionToAzimuthElevation(FrameDirectionAt(five, FrameIndex(5, {1, 2})));
  EXPECT_NEAR(ae.x * 180.0f / std::numbers::pi_v<float>, 72.0f, 1e-3f);
}

TEST(AzimuthElevation, AzimuthWrapsWithoutASeam) {
  const ViewLayout layout{LayoutKind::kAzimuthElevation, 5, 0};
  // Just either side of az = 0 (the +Z column): both pick column 0.
  for (float az : {-0.01f, 0.0f, 0.01f}) {
    const glm::vec3 d = AzimuthElevationToDirection(az, 0.0f);
    EXPECT_EQ(NearestFrame(layout, d), FrameIndex(5, {0, 2})) << az;
  }
}

TEST(RingTop, TwentyFourViewsFifteenDegreesApartPlusTop) {
  const ViewLayout layout{LayoutKind::kRingTop, 0, 24};
  ASSERT_EQ(FrameCount(layout), 25);
  EXPECT_EQ(GridSide(layout), 5);
  for (int k = 0; k < 24; ++k) {
    const glm::vec3 d = FrameDirectionAt(layout, k);
    EXPECT_NEAR(d.y, 0.0f, 1e-6f);
    const glm::vec3 next = FrameDirectionAt(layout, (k + 1) % 24);
    EXPECT_NEAR(AngleDeg(d, next), 15.0f, 1e-3f) << k;
  }
  EXPECT_LT(glm::length(FrameDirectionAt(layout, 24) - glm::vec3(0, 1, 0)), 1e-6f);
  // Straight down has no frame of its own: the ring answers (lowest index
  // on a tie), never the top view.
  EXPECT_LT(NearestFrame(layout, {0, -1, 0}), 24);
  // Exactly half-way between ring frames 0 and 1 (7.5 degrees): the lower.
  EXPECT_EQ(NearestFrame(layout, AzimuthElevationToDirection(7.5f * std::numbers::pi_v<float> / 180.0f, 0.0f)), 0);
  // Above 45 degrees elevation the top view is nearer than any ring view.
  EXPECT_EQ(NearestFrame(layout, AzimuthElevationToDirection(0.0f, 0.8f)), 24);
  EXPECT_EQ(NearestFrame(layout, AzimuthElevationToDirection(0.0f, 0.7f)), 0);
}

TEST(Billboard, EightSidesEveryFortyFiveDegreesAndATopInThreeByThree) {
  const ViewLayout layout{LayoutKind::kBillboard, 0, kBillboardRingViews};
  ASSERT_EQ(FrameCount(layout), 9);
  EXPECT_EQ(GridSide(layout), 3);
  for (int k = 0; k < 8; ++k) {
    const glm::vec2 ae = DirectionToAzimuthElevation(FrameDirectionAt(layout, k));
    EXPECT_NEAR(ae.x * 180.0f / std::numbers::pi_v<float>, 45.0f * k, 1e-3f) << k;
    EXPECT_NEAR(ae.y, 0.0f, 1e-6f);
  }
  EXPECT_EQ(FrameTile(layout, 8), (FrameCoord{2, 2}));
}

TEST(ViewLayout, ParseAndNameRoundTrip) {
  for (LayoutKind k : {LayoutKind::kOctahedral, LayoutKind::kHemiOctahedral, LayoutKind::kAzimuthElevation,
                       LayoutKind::kRingTop, LayoutKind::kBillboard}) {
    auto parsed = ParseLayout(LayoutName(k));
    ASSERT_TRUE(parsed.ok()) << LayoutName(k);
    EXPECT_EQ(*parsed, k);
  }
  EXPECT_FALSE(ParseLayout("cube-map").ok());
}

}  // namespace
}  // namespace impostor
