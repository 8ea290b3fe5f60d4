// Frame blend weights: the properties every runtime relies on, for both
// layouts, both blend modes and several grid sizes.
#include "common/runtime/frame_blend.h"

#include <cmath>
#include <limits>
#include <map>
#include <random>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

namespace impostor {
namespace {

struct Case {
  LayoutKind layout;
  int frames;
  BlendMode mode;
};

std::string CaseName(const ::testing::TestParamInfo<Case>& info) {
  std::string name = std::string(LayoutName(info.param.layout)) + "_" + std::to_string(info.param.frames) +
                     "_" + std::string(BlendModeName(info.param.mode));
  for (char& c : name) {
    if (c == '-') c = '_';
  }
  return name;
}

std::vector<Case> AllCases() {
  std::vector<Case> cases;
  for (LayoutKind layout : {LayoutKind::kOctahedral, LayoutKind::kHemiOctahedral}) {
    for (int frames : {2, 3, 6, 8, 12, 16}) {
      for (BlendMode mode : {BlendMode::kTriangle3, BlendMode::kBilinear4}) cases.push_back({layout, frames, mode});
    }
  }
  return cases;
}

// Weights by frame index, with every frame mapped to its canonical frame.
std::map<int, float> Weights(const FrameBlend& blend) {
  std::map<int, float> w;
  for (int i = 0; i < blend.count; ++i) w[blend.entries[i].index] += blend.entries[i].weight;
  return w;
}

// Largest per-frame weight difference between two blends.
float WeightDistance(const FrameBlend& a, const FrameBlend& b) {
  std::map<int, float> wa = Weights(a), wb = Weights(b);
  float worst = 0.0f;
  for (const auto& [index, w] : wa) worst = std::max(worst, std::abs(w - (wb.count(index) ? wb[index] : 0.0f)));
  for (const auto& [index, w] : wb) worst = std::max(worst, std::abs(w - (wa.count(index) ? wa[index] : 0.0f)));
  return worst;
}

glm::vec3 RandomDirection(std::mt19937& rng, LayoutKind layout) {
  std::normal_distribution<float> n(0.0f, 1.0f);
  glm::vec3 d(n(rng), n(rng), n(rng));
  if (layout == LayoutKind::kHemiOctahedral) d.y = std::abs(d.y);
  return glm::normalize(d);
}

class FrameBlendTest : public ::testing::TestWithParam<Case> {};

TEST_P(FrameBlendTest, WeightsArePositiveCanonicalAndSumToOne) {
  const Case c = GetParam();
  std::mt19937 rng(42);
  for (int i = 0; i < 5000; ++i) {
    const glm::vec3 d = RandomDirection(rng, c.layout);
    const FrameBlend blend = BlendFrames(c.layout, c.frames, d, c.mode);
    ASSERT_GE(blend.count, 1);
    ASSERT_LE(blend.count, c.mode == BlendMode::kTriangle3 ? 3 : 4);
    float sum = 0.0f;
    for (int k = 0; k < blend.count; ++k) {
      const FrameWeight& e = blend.entries[k];
      EXPECT_GT(e.weight, 0.0f);
      EXPECT_EQ(e.index, FrameIndex(c.frames, e.frame));
      EXPECT_EQ(CanonicalFrame(c.layout, c.frames, e.frame), e.frame);
      for (int j = 0; j < k; ++j) EXPECT_NE(blend.entries[j].index, e.index) << "frame listed twice";
      sum += e.weight;
    }
    EXPECT_NEAR(sum, 1.0f, 1e-6f);
  }
}

TEST_P(FrameBlendTest, FullWeightOnEveryFrameAtItsOwnDirection) {
  const Case c = GetParam();
  for (int row = 0; row < c.frames; ++row) {
    for (int col = 0; col < c.frames; ++col) {
      const FrameCoord f{col, row};
      const FrameBlend blend = BlendFrames(c.layout, c.frames, FrameDirection(c.layout, c.frames, f), c.mode);
      const int canonical = FrameIndex(c.frames, CanonicalFrame(c.layout, c.frames, f));
      std::map<int, float> w = Weights(blend);
      EXPECT_NEAR(w[canonical], 1.0f, 1e-5f) << "frame " << col << "," << row;
      // The frame the runtime blends is the one the baker encodes.
      EXPECT_EQ(FrameIndex(c.frames, EncodeFrame(c.layout, c.frames, FrameDirection(c.layout, c.frames, f))),
                canonical);
    }
  }
}

// Random pairs of directions 1e-4 apart anywhere on the domain (some cross
// cell edges, diagonals, the octahedron's axes or its folded border): the
// weights may change only a little.
TEST_P(FrameBlendTest, ContinuousBetweenRandomNearbyDirections) {
  const Case c = GetParam();
  std::mt19937 rng(7);
  const float step = 1e-4f;
  // Per unit of direction change the grid moves by at most ~frames (the
  // octahedral map's Lipschitz constant is below 2 per unit of oct, and oct
  // spans frames-1 grid units over 2), so a bilinear weight moves by at most
  // about 2 * frames * step.
  const float tolerance = 4.0f * static_cast<float>(c.frames) * step + 1e-5f;
  for (int i = 0; i < 20000; ++i) {
    const glm::vec3 a = RandomDirection(rng, c.layout);
    glm::vec3 perp = glm::normalize(glm::cross(a, RandomDirection(rng, c.layout)));
    const glm::vec3 b = glm::normalize(a + perp * step);
    if (c.layout == LayoutKind::kHemiOctahedral && b.y < 0.0f) continue;
    const FrameBlend ba = BlendFrames(c.layout, c.frames, a, c.mode);
    const FrameBlend bb = BlendFrames(c.layout, c.frames, b, c.mode);
    ASSERT_LE(WeightDistance(ba, bb), tolerance) << "direction " << a.x << "," << a.y << "," << a.z;
  }
}

// Pairs of directions 1e-4 apart placed exactly across each cell edge and
// each triangle diagonal of the grid (in the grid's own coordinates).
TEST_P(FrameBlendTest, ContinuousAcrossEveryGridLineAndDiagonal) {
  const Case c = GetParam();
  if (c.frames < 2) GTEST_SKIP();
  const float n1 = static_cast<float>(c.frames - 1);
  auto dir_at = [&](glm::vec2 grid) {
    return LayoutToDirection(c.layout, glm::clamp(grid / n1 * 2.0f - 1.0f, glm::vec2(-1.0f), glm::vec2(1.0f)));
  };
  const float e = 1e-4f;
  const float tolerance = 4.0f * e * static_cast<float>(c.frames) + 1e-4f;
  int pairs = 0;
  for (int line = 1; line < c.frames - 1; ++line) {
    for (float along = 0.13f; along < n1; along += 0.37f) {
      const float l = static_cast<float>(line);
      // Vertical and horizontal cell edges.
      for (auto [p, q] : {std::pair{glm::vec2(l - e, along), glm::vec2(l + e, along)},
                          std::pair{glm::vec2(along, l - e), glm::vec2(along, l + e)}}) {
        const float d = WeightDistance(BlendFrames(c.layout, c.frames, dir_at(p), c.mode),
                                       BlendFrames(c.layout, c.frames, dir_at(q), c.mode));
        EXPECT_LE(d, tolerance) << "across grid line at " << p.x << "," << p.y;
        ++pairs;
      }
    }
  }
  // The c0-c3 diagonal of every quad, where triangle3 switches triangles.
  for (int y = 0; y < c.frames - 1; ++y) {
    for (int x = 0; x < c.frames - 1; ++x) {
      for (float f : {0.2f, 0.5f, 0.8f}) {
        const glm::vec2 on(static_cast<float>(x) + f, static_cast<float>(y) + f);
        const glm::vec2 off(e, -e);
        const float d = WeightDistance(BlendFrames(c.layout, c.frames, dir_at(on + off), c.mode),
                                       BlendFrames(c.layout, c.frames, dir_at(on - off), c.mode));
        EXPECT_LE(d, tolerance) << "across the diagonal of quad " << x << "," << y;
        ++pairs;
      }
    }
  }
  EXPECT_GT(pairs, 0);
}

INSTANTIATE_TEST_SUITE_P(Layouts, FrameBlendTest, ::testing::ValuesIn(AllCases()), CaseName);

// On the full octahedron a direction just below the fold and its mirror
// image just above it (the two sides of the atlas's outer edge) get the same
// canonical frames and weights.
TEST(FrameBlendFold, DuplicateBorderFramesMergeIntoTheCanonicalFrame) {
  const int frames = 8;
  for (BlendMode mode : {BlendMode::kTriangle3, BlendMode::kBilinear4}) {
    for (float t = -0.95f; t <= 0.95f; t += 0.1f) {
      // The right edge oct (1, t) and (1, -t) are one direction: y = 0 plane.
      const glm::vec3 on_edge = OctahedralToDirection({1.0f, t});
      const glm::vec3 mirrored = OctahedralToDirection({1.0f, -t});
      ASSERT_NEAR(glm::distance(on_edge, mirrored), 0.0f, 1e-5f);
      // Slightly below the horizon, slightly above: weights must agree.
      const glm::vec3 below = glm::normalize(on_edge + glm::vec3(0, -1e-4f, 0));
      const glm::vec3 above = glm::normalize(on_edge + glm::vec3(0, 1e-4f, 0));
      const FrameBlend a = BlendFrames(LayoutKind::kOctahedral, frames, below, mode);
      const FrameBlend b = BlendFrames(LayoutKind::kOctahedral, frames, above, mode);
      EXPECT_LE(WeightDistance(a, b), 4e-3f) << "t=" << t;
      // Only canonical frames, no frame twice.
      for (int k = 0; k < a.count; ++k) {
        EXPECT_EQ(CanonicalFrame(LayoutKind::kOctahedral, frames, a.entries[k].frame), a.entries[k].frame);
      }
    }
    // The -Y pole: all four corners are one frame with full weight.
    const FrameBlend pole = BlendFrames(LayoutKind::kOctahedral, frames, {0, -1, 0}, mode);
    ASSERT_EQ(pole.count, 1);
    EXPECT_EQ(pole.entries[0].index, 0);
    EXPECT_FLOAT_EQ(pole.entries[0].weight, 1.0f);
    // On a border frame's duplicate pair, full weight lands on the lower index.
    const FrameCoord dup{frames - 1, frames - 3};  // mirrors (frames - 1, 2)
    const FrameCoord canonical = CanonicalFrame(LayoutKind::kOctahedral, frames, dup);
    ASSERT_NE(canonical, dup);
    const FrameBlend at = BlendFrames(LayoutKind::kOctahedral, frames,
                                      FrameDirection(LayoutKind::kOctahedral, frames, dup), mode);
    EXPECT_NEAR(Weights(at)[FrameIndex(frames, canonical)], 1.0f, 1e-5f);
  }
}

// The article's weights at known grid positions.
TEST(FrameBlendWeights, MatchTheSeedFormulas) {
  const int frames = 5;  // grid spacing 0.5 in oct space
  const LayoutKind layout = LayoutKind::kHemiOctahedral;
  auto dir_at = [&](glm::vec2 grid) { return LayoutToDirection(layout, grid / 4.0f * 2.0f - 1.0f); };
  struct Expect {
    glm::vec2 grid;
    BlendMode mode;
    std::map<int, float> weights;  // index -> weight
  };
  // Quad (1,1)-(2,2): c0 = 6, c1 = 7, c2 = 11, c3 = 12; fx = 0.25, fy = 0.5.
  const std::vector<Expect> cases = {
      {{1.25f, 1.5f}, BlendMode::kBilinear4, {{6, 0.375f}, {7, 0.125f}, {11, 0.375f}, {12, 0.125f}}},
      // fy > fx: lower frame; A = 1 - 0.5, B = 0.25, C = 0.25.
      {{1.25f, 1.5f}, BlendMode::kTriangle3, {{6, 0.5f}, {11, 0.25f}, {12, 0.25f}}},
      // fx > fy: right frame; A = 1 - 0.75, B = 0.5, C = 0.25.
      {{1.75f, 1.25f}, BlendMode::kTriangle3, {{6, 0.25f}, {7, 0.5f}, {12, 0.25f}}},
  };
  for (const Expect& e : cases) {
    const std::map<int, float> got = Weights(BlendFrames(layout, frames, dir_at(e.grid), e.mode));
    ASSERT_EQ(got.size(), e.weights.size()) << BlendModeName(e.mode);
    for (const auto& [index, w] : e.weights) {
      ASSERT_TRUE(got.count(index)) << "frame " << index;
      EXPECT_NEAR(got.at(index), w, 1e-4f) << BlendModeName(e.mode) << " frame " << index;
    }
  }
}

TEST(FrameBlendDegenerate, ZeroAndNonFiniteDirectionsAreStraightUp) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  for (LayoutKind layout : {LayoutKind::kOctahedral, LayoutKind::kHemiOctahedral}) {
    const std::map<int, float> up = Weights(BlendFrames(layout, 9, {0, 1, 0}, BlendMode::kBilinear4));
    for (glm::vec3 d : {glm::vec3(0.0f), glm::vec3(nan, 0, 0), glm::vec3(inf, 1, 0)}) {
      EXPECT_EQ(Weights(BlendFrames(layout, 9, d, BlendMode::kBilinear4)), up);
    }
  }
}

TEST(BlendModeNames, RoundTripAndRejectUnknown) {
  for (BlendMode mode : {BlendMode::kTriangle3, BlendMode::kBilinear4}) {
    auto parsed = ParseBlendMode(BlendModeName(mode));
    ASSERT_TRUE(parsed.ok());
    EXPECT_EQ(*parsed, mode);
  }
  auto bad = ParseBlendMode("trilinear");
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(bad.status().message().find("triangle3"), std::string::npos);
}

}  // namespace
}  // namespace impostor
