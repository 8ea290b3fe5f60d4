// Frame blend weights of every layout through the layout-generic entry point
// BlendFrames(const ViewLayout&, ...): azimuth-elevation, ring-top and
// billboard in particular (the octahedral grids have their own tests in
// frame_blend_test.cc), several sizes, both blend modes.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "common/atlas/atlas_layout.h"
#include "common/runtime/frame_blend.h"

namespace impostor {
namespace {

constexpr float kPi = 3.14159265358979323846f;

struct Case {
  ViewLayout layout;
  BlendMode mode;
};

std::string CaseName(const ::testing::TestParamInfo<Case>& info) {
  const ViewLayout& l = info.param.layout;
  std::string name = std::string(LayoutName(l.kind)) + "_" +
                     std::to_string(l.kind == LayoutKind::kRingTop ? l.ring_views : l.frames) + "_" +
                     std::string(BlendModeName(info.param.mode));
  for (char& c : name) {
    if (c == '-') c = '_';
  }
  return name;
}

bool IsRing(const ViewLayout& l) { return l.kind == LayoutKind::kRingTop || l.kind == LayoutKind::kBillboard; }

std::vector<Case> AllCases() {
  std::vector<ViewLayout> layouts = {{LayoutKind::kOctahedral, 8, 0}, {LayoutKind::kHemiOctahedral, 8, 0}};
  for (int n : {3, 5, 11, 21}) layouts.push_back({LayoutKind::kAzimuthElevation, n, 0});
  for (int k : {3, 8, 24, 64}) {
    ViewLayout l{LayoutKind::kRingTop, 0, k};
    l.frames = GridSide(l);  // as the request carries it
    layouts.push_back(l);
  }
  layouts.push_back({LayoutKind::kBillboard, 3, kBillboardRingViews});
  std::vector<Case> cases;
  for (const ViewLayout& l : layouts) {
    for (BlendMode mode : {BlendMode::kTriangle3, BlendMode::kBilinear4}) cases.push_back({l, mode});
  }
  return cases;
}

std::map<int, float> Weights(const FrameBlend& blend) {
  std::map<int, float> w;
  for (int i = 0; i < blend.count; ++i) w[blend.entries[i].index] += blend.entries[i].weight;
  return w;
}

float WeightDistance(const FrameBlend& a, const FrameBlend& b) {
  std::map<int, float> wa = Weights(a), wb = Weights(b);
  float worst = 0.0f;
  for (const auto& [index, w] : wa) worst = std::max(worst, std::abs(w - (wb.count(index) ? wb[index] : 0.0f)));
  for (const auto& [index, w] : wb) worst = std::max(worst, std::abs(w - (wa.count(index) ? wa[index] : 0.0f)));
  return worst;
}

// The domain where a layout's weights are continuous: the whole sphere for
// octahedral and azimuth-elevation; the upper hemisphere for
// hemi-octahedral; for the ring layouts everything but a cap around -Y
// (below the horizon they blend the ring only, as hemi-octahedral clamps
// onto its horizon; here: elevation >= -60 degrees).
float MinElevation(const ViewLayout& l) {
  if (l.kind == LayoutKind::kHemiOctahedral) return 0.0f;
  if (IsRing(l)) return -kPi / 3.0f;
  return -kPi / 2.0f;
}

glm::vec3 RandomDirection(std::mt19937& rng, const ViewLayout& l) {
  std::normal_distribution<float> n(0.0f, 1.0f);
  for (;;) {
    const glm::vec3 d = glm::normalize(glm::vec3(n(rng), n(rng), n(rng)));
    if (std::asin(std::clamp(d.y, -1.0f, 1.0f)) >= MinElevation(l)) return d;
  }
}

// Largest change of any weight per radian of direction change, from the
// blend's formulas (see frame_blend.h), with headroom 2x.
float Lipschitz(const ViewLayout& l) {
  const int n = l.frames;
  switch (l.kind) {
    case LayoutKind::kOctahedral:
    case LayoutKind::kHemiOctahedral:
      return 4.0f * static_cast<float>(n);
    case LayoutKind::kAzimuthElevation:
      // Azimuth: N / (2 pi cos el), largest on the rows next to the poles
      // (the caps scale it down by 1 - t); elevation: N / pi per row, 2N / pi
      // in the caps. Two weights change at once.
      return 2.0f * (static_cast<float>(n) / (2.0f * kPi * std::sin(kPi / (2.0f * n))) +
                     2.0f * static_cast<float>(n) / kPi);
    case LayoutKind::kRingTop:
    case LayoutKind::kBillboard: {
      const int k = l.kind == LayoutKind::kBillboard ? kBillboardRingViews : l.ring_views;
      // Azimuth: (1 - t) K / (2 pi cos el) <= K / (2 pi) above the horizon,
      // K / (2 pi cos el_min) below; elevation: 2 / pi.
      return 2.0f * (static_cast<float>(k) / (2.0f * kPi * std::cos(MinElevation(l))) + 2.0f / kPi);
    }
  }
  return 1.0f;
}

class LayoutBlendTest : public ::testing::TestWithParam<Case> {};

TEST_P(LayoutBlendTest, WeightsArePositiveDistinctAndSumToOne) {
  const Case c = GetParam();
  std::mt19937 rng(42);
  std::normal_distribution<float> n(0.0f, 1.0f);
  const int max_count = IsRing(c.layout) || c.mode == BlendMode::kTriangle3 ? 3 : 4;
  std::vector<glm::vec3> dirs = {{0, 1, 0}, {0, -1, 0}, {1, 0, 0}, {0, 0, 1}, {0, 0, -1}, {-1, 0, 0}};
  for (int i = 0; i < 5000; ++i) dirs.push_back(glm::normalize(glm::vec3(n(rng), n(rng), n(rng))));
  for (const glm::vec3& d : dirs) {
    const FrameBlend blend = BlendFrames(c.layout, d, c.mode);
    ASSERT_GE(blend.count, 1);
    ASSERT_LE(blend.count, max_count);
    float sum = 0.0f;
    for (int k = 0; k < blend.count; ++k) {
      const FrameWeight& e = blend.entries[k];
      EXPECT_GT(e.weight, 0.0f);
      ASSERT_GE(e.index, 0);
      ASSERT_LT(e.index, FrameCount(c.layout));
      EXPECT_EQ(e.frame, FrameTile(c.layout, e.index));
      EXPECT_EQ(CanonicalFrameIndex(c.layout, e.index), e.index);
      for (int j = 0; j < k; ++j) EXPECT_NE(blend.entries[j].index, e.index) << "frame listed twice";
      sum += e.weight;
    }
    EXPECT_NEAR(sum, 1.0f, 1e-6f);
  }
}

// Full weight on every frame seen from its own direction, and that frame is
// the one NearestFrame picks (the baker and the runtime agree).
TEST_P(LayoutBlendTest, FullWeightOnEveryFrameAtItsOwnDirection) {
  const Case c = GetParam();
  for (int i = 0; i < FrameCount(c.layout); ++i) {
    const glm::vec3 d = FrameDirectionAt(c.layout, i);
    const int canonical = CanonicalFrameIndex(c.layout, i);
    std::map<int, float> w = Weights(BlendFrames(c.layout, d, c.mode));
    EXPECT_NEAR(w[canonical], 1.0f, 1e-5f) << "frame " << i;
    EXPECT_EQ(NearestFrame(c.layout, d), canonical) << "frame " << i;
  }
}

// Wherever the weights sit on a single frame, it is NearestFrame's frame:
// random directions, and the places built to give one frame (frame
// directions, a column's azimuth inside the pole caps, the poles, a ring
// frame's azimuth below the horizon).
TEST_P(LayoutBlendTest, SingleFramePickAgreesWithNearestFrame) {
  const Case c = GetParam();
  std::vector<glm::vec3> dirs = {{0, 1, 0}, {0, -1, 0}};
  std::mt19937 rng(5);
  for (int i = 0; i < 2000; ++i) dirs.push_back(RandomDirection(rng, c.layout));
  for (int i = 0; i < FrameCount(c.layout); ++i) dirs.push_back(FrameDirectionAt(c.layout, i));
  if (c.layout.kind == LayoutKind::kAzimuthElevation) {
    const int n = c.layout.frames;
    const float cap = kPi / (2.0f * n);  // rows 0 and N-1 are this far from the poles
    for (int col = 0; col < n; ++col) {
      const float az = static_cast<float>(col) * 2.0f * kPi / n;
      // Column 0 inside the caps: all weight on that column's cap frame.
      if (col == 0) {
        for (float f : {0.3f, 0.7f}) {
          dirs.push_back(AzimuthElevationToDirection(az, 0.5f * kPi - f * cap));
          dirs.push_back(AzimuthElevationToDirection(az, -0.5f * kPi + f * cap));
        }
      }
    }
  }
  if (IsRing(c.layout)) {
    const int k = c.layout.kind == LayoutKind::kBillboard ? kBillboardRingViews : c.layout.ring_views;
    for (int i = 0; i < k; ++i) {
      dirs.push_back(AzimuthElevationToDirection(static_cast<float>(i) * 2.0f * kPi / k, -0.4f));
    }
  }
  int single = 0;
  for (const glm::vec3& d : dirs) {
    const FrameBlend blend = BlendFrames(c.layout, d, c.mode);
    int best = 0;
    for (int k = 1; k < blend.count; ++k) {
      if (blend.entries[k].weight > blend.entries[best].weight) best = k;
    }
    if (blend.entries[best].weight < 1.0f - 1e-6f) continue;
    ++single;
    EXPECT_EQ(blend.entries[best].index, NearestFrame(c.layout, d))
        << "direction " << d.x << "," << d.y << "," << d.z;
  }
  EXPECT_GE(single, FrameCount(c.layout) / 2);
}

// Random pairs of directions 1e-4 apart over the layout's domain.
TEST_P(LayoutBlendTest, ContinuousBetweenRandomNearbyDirections) {
  const Case c = GetParam();
  std::mt19937 rng(7);
  const float step = 1e-4f;
  const float tolerance = Lipschitz(c.layout) * step + 2e-5f;
  float worst = 0.0f;
  for (int i = 0; i < 20000; ++i) {
    const glm::vec3 a = RandomDirection(rng, c.layout);
    const glm::vec3 perp = glm::normalize(glm::cross(a, RandomDirection(rng, c.layout)));
    const glm::vec3 b = glm::normalize(a + perp * step);
    if (std::asin(std::clamp(b.y, -1.0f, 1.0f)) < MinElevation(c.layout)) continue;
    const float d = WeightDistance(BlendFrames(c.layout, a, c.mode), BlendFrames(c.layout, b, c.mode));
    worst = std::max(worst, d);
    ASSERT_LE(d, tolerance) << "direction " << a.x << "," << a.y << "," << a.z;
  }
  EXPECT_GT(worst, 0.0f);
}

// Pairs 1e-4 apart placed exactly across every boundary where the blend
// switches cells: each column's meridian (column 0's is the azimuth wrap),
// each row's and the ring's elevation, and around the poles (a pair on
// opposite sides of the Y axis, whose azimuths differ by 180 degrees).
TEST_P(LayoutBlendTest, ContinuousAcrossCellBoundariesTheWrapAndThePoles) {
  const Case c = GetParam();
  if (c.layout.kind != LayoutKind::kAzimuthElevation && !IsRing(c.layout)) {
    GTEST_SKIP() << "octahedral grid lines: frame_blend_test.cc";
  }
  const float e = 5e-5f;  // each side: pairs are 1e-4 apart
  const float tolerance = Lipschitz(c.layout) * 2.0f * e + 2e-5f;
  const bool grid = c.layout.kind == LayoutKind::kAzimuthElevation;
  const int columns = grid ? c.layout.frames
                           : (c.layout.kind == LayoutKind::kBillboard ? kBillboardRingViews : c.layout.ring_views);
  std::vector<float> elevations;  // where to cross meridians
  for (float el = MinElevation(c.layout) + 0.05f; el < 0.5f * kPi - 0.01f; el += 0.1f) elevations.push_back(el);
  std::vector<float> boundary_elevations = {0.0f};  // parallels where the blend switches
  if (grid) {
    boundary_elevations.clear();
    for (int r = 0; r < c.layout.frames; ++r) {
      boundary_elevations.push_back(0.5f * kPi - (r + 0.5f) * kPi / c.layout.frames);
    }
  }
  int pairs = 0;
  float worst = 0.0f;
  auto check = [&](glm::vec3 p, glm::vec3 tangent, const char* what) {
    const glm::vec3 a = glm::normalize(p + e * tangent), b = glm::normalize(p - e * tangent);
    const float d = WeightDistance(BlendFrames(c.layout, a, c.mode), BlendFrames(c.layout, b, c.mode));
    worst = std::max(worst, d);
    ++pairs;
    EXPECT_LE(d, tolerance) << what << " at " << p.x << "," << p.y << "," << p.z;
  };
  for (int col = 0; col < columns; ++col) {
    const float az = static_cast<float>(col) * 2.0f * kPi / columns;
    const glm::vec3 east(std::cos(az), 0.0f, -std::sin(az));  // d(direction)/d(azimuth), unit
    for (float el : elevations) check(AzimuthElevationToDirection(az, el), east, "meridian");
    // Across the parallels, at the column and half way to the next.
    for (float el : boundary_elevations) {
      for (float a : {az, az + kPi / columns}) {
        const glm::vec3 north(-std::sin(el) * std::sin(a), std::cos(el), -std::sin(el) * std::cos(a));
        check(AzimuthElevationToDirection(a, el), north, "parallel");
      }
    }
  }
  // The poles, approached from opposite azimuths.
  for (int i = 0; i < 16; ++i) {
    const float az = static_cast<float>(i) * 0.41f;
    const glm::vec3 horizontal(std::sin(az), 0.0f, std::cos(az));
    check({0.0f, 1.0f, 0.0f}, horizontal, "+Y pole");
    if (grid) check({0.0f, -1.0f, 0.0f}, horizontal, "-Y pole");
  }
  std::printf("[ figures  ] %s: %d boundary pairs 1e-4 apart, largest weight change %.2e (bound %.2e)\n",
              CaseName(::testing::TestParamInfo<Case>(GetParam(), 0)).c_str(), pairs, worst, tolerance);
}

INSTANTIATE_TEST_SUITE_P(Layouts, LayoutBlendTest, ::testing::ValuesIn(AllCases()), CaseName);

// The documented weights at known places.
TEST(LayoutBlendWeights, MatchTheDocumentedFormulas) {
  const ViewLayout ae{LayoutKind::kAzimuthElevation, 5, 0};  // 72 deg columns, 36 deg rows at 72, 36, 0, ...
  const float deg = kPi / 180.0f;
  // Azimuth 18 deg (fx = 0.25) between rows 1 (36 deg) and 2 (0 deg) at
  // 9 deg (v = 1.75, fy = 0.75): cell (0, 1)-(1, 2).
  const glm::vec3 d = AzimuthElevationToDirection(18.0f * deg, 9.0f * deg);
  const std::map<int, float> bilinear = Weights(BlendFrames(ae, d, BlendMode::kBilinear4));
  const std::map<int, float> want_bilinear = {{5, 0.75f * 0.25f}, {6, 0.25f * 0.25f}, {10, 0.75f * 0.75f},
                                              {11, 0.25f * 0.75f}};
  ASSERT_EQ(bilinear.size(), want_bilinear.size());
  for (const auto& [i, w] : want_bilinear) EXPECT_NEAR(bilinear.at(i), w, 1e-5f) << i;
  // Triangle3, fy > fx: c0 = 1 - 0.75, c2 = 0.5, c3 = 0.25.
  const std::map<int, float> tri = Weights(BlendFrames(ae, d, BlendMode::kTriangle3));
  const std::map<int, float> want_tri = {{5, 0.25f}, {10, 0.5f}, {11, 0.25f}};
  ASSERT_EQ(tri.size(), want_tri.size());
  for (const auto& [i, w] : want_tri) EXPECT_NEAR(tri.at(i), w, 1e-5f) << i;
  // The wrap: azimuth 324 deg (fx = 0.5 between columns 4 and 0) on row 2.
  const std::map<int, float> wrap =
      Weights(BlendFrames(ae, AzimuthElevationToDirection(324.0f * deg, 0.0f), BlendMode::kBilinear4));
  EXPECT_NEAR(wrap.at(14), 0.5f, 1e-5f);
  EXPECT_NEAR(wrap.at(10), 0.5f, 1e-5f);
  // Half way from row 0 (72 deg) to the pole, at column 1's azimuth: half
  // on (1, 0), half on the cap frame (0, 0).
  const std::map<int, float> cap =
      Weights(BlendFrames(ae, AzimuthElevationToDirection(72.0f * deg, 81.0f * deg), BlendMode::kBilinear4));
  EXPECT_NEAR(cap.at(1), 0.5f, 1e-4f);
  EXPECT_NEAR(cap.at(0), 0.5f, 1e-4f);

  // Ring-top, K = 4: azimuth 30 deg (fx = 1/3), elevation 30 deg (t = 1/3).
  const ViewLayout ring{LayoutKind::kRingTop, 3, 4};
  const std::map<int, float> r =
      Weights(BlendFrames(ring, AzimuthElevationToDirection(30.0f * deg, 30.0f * deg), BlendMode::kTriangle3));
  EXPECT_NEAR(r.at(0), (2.0f / 3.0f) * (2.0f / 3.0f), 1e-5f);
  EXPECT_NEAR(r.at(1), (2.0f / 3.0f) * (1.0f / 3.0f), 1e-5f);
  EXPECT_NEAR(r.at(4), 1.0f / 3.0f, 1e-5f);
  // Below the horizon: the ring only.
  const std::map<int, float> below =
      Weights(BlendFrames(ring, AzimuthElevationToDirection(45.0f * deg, -20.0f * deg), BlendMode::kBilinear4));
  EXPECT_EQ(below.size(), 2u);
  EXPECT_NEAR(below.at(0), 0.5f, 1e-5f);
  EXPECT_NEAR(below.at(1), 0.5f, 1e-5f);
  // Both modes agree on the ring layouts; the (kind, frames) form of
  // billboard is its ViewLayout form.
  for (int i = 0; i < 100; ++i) {
    const glm::vec3 v = AzimuthElevationToDirection(0.7f * i, 0.013f * i - 0.3f);
    EXPECT_EQ(Weights(BlendFrames(ring, v, BlendMode::kTriangle3)), Weights(BlendFrames(ring, v, BlendMode::kBilinear4)));
    EXPECT_EQ(Weights(BlendFrames(LayoutKind::kBillboard, 3, v, BlendMode::kTriangle3)),
              Weights(BlendFrames(ViewLayout{LayoutKind::kBillboard, 3, 8}, v, BlendMode::kTriangle3)));
  }
}

TEST(LayoutBlendDegenerate, EmptyLayoutsAndBadDirections) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (ViewLayout l : {ViewLayout{LayoutKind::kRingTop, 0, 0}, ViewLayout{LayoutKind::kAzimuthElevation, 1, 0}}) {
    const FrameBlend b = BlendFrames(l, {0.3f, 0.2f, 0.1f}, BlendMode::kBilinear4);
    ASSERT_EQ(b.count, 1);
    EXPECT_EQ(b.entries[0].index, 0);
    EXPECT_EQ(b.entries[0].weight, 1.0f);
  }
  for (ViewLayout l : {ViewLayout{LayoutKind::kRingTop, 5, 24}, ViewLayout{LayoutKind::kAzimuthElevation, 11, 0}}) {
    const std::map<int, float> up = Weights(BlendFrames(l, {0, 1, 0}, BlendMode::kBilinear4));
    EXPECT_EQ(Weights(BlendFrames(l, glm::vec3(0.0f), BlendMode::kBilinear4)), up);
    EXPECT_EQ(Weights(BlendFrames(l, glm::vec3(nan, 0, 0), BlendMode::kBilinear4)), up);
  }
}

}  // namespace
}  // namespace impostor
