// SimplifyTriangles on synthetic meshes: counts, errors in position units,
// locked material borders, and the sloppy fallback.
#include "worker/lod/lod_simplify.h"

#include <cmath>
#include <set>
#include <utility>

#include <gtest/gtest.h>

namespace impostor {
namespace {

// An n x n grid of quads on a bumpy surface, `size` units wide.
struct Grid {
  std::vector<float> positions;
  std::vector<uint32_t> indices;
};

Grid MakeGrid(int n, float size, float x0 = 0.0f) {
  Grid g;
  for (int y = 0; y <= n; ++y) {
    for (int x = 0; x <= n; ++x) {
      const float u = static_cast<float>(x) / n, v = static_cast<float>(y) / n;
      g.positions.insert(g.positions.end(),
                         {x0 + u * size, 0.05f * size * std::sin(6.0f * u) * std::cos(5.0f * v), v * size});
    }
  }
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      const uint32_t a = y * (n + 1) + x, b = a + 1, c = a + n + 1, d = c + 1;
      g.indices.insert(g.indices.end(), {a, c, b, b, c, d});
    }
  }
  return g;
}

struct RatioCase {
  float ratio;
};

class SimplifyRatioTest : public ::testing::TestWithParam<RatioCase> {};

TEST_P(SimplifyRatioTest, ReachesTheTargetWithinTenPercent) {
  const Grid g = MakeGrid(48, 2.0f);
  const size_t triangles = g.indices.size() / 3;
  const SimplifyResult r = SimplifyTriangles(g.indices, g.positions, GetParam().ratio);
  const double target = GetParam().ratio * triangles;
  EXPECT_NEAR(r.indices.size() / 3.0, target, 0.1 * target) << "ratio " << GetParam().ratio;
  EXPECT_NE(r.method, SimplifyMethod::kSloppy) << "a connected surface simplifies with quadrics";
  EXPECT_GT(r.error, 0.0f);
  EXPECT_LT(r.error, 0.2f) << "error is in position units, a fraction of the 2-unit grid";
}

INSTANTIATE_TEST_SUITE_P(Ratios, SimplifyRatioTest,
                         ::testing::Values(RatioCase{0.75f}, RatioCase{0.5f}, RatioCase{0.25f}, RatioCase{0.1f}),
                         [](const auto& info) { return "ratio_" + std::to_string(static_cast<int>(info.param.ratio * 100)); });

TEST(SimplifyTest, ErrorGrowsAsRatioShrinks) {
  const Grid g = MakeGrid(48, 2.0f);
  float previous = 0.0f;
  for (float ratio : {0.5f, 0.25f, 0.1f, 0.03f}) {
    const SimplifyResult r = SimplifyTriangles(g.indices, g.positions, ratio);
    EXPECT_GT(r.error, previous) << "ratio " << ratio;
    previous = r.error;
  }
}

TEST(SimplifyTest, ErrorScalesWithTheMesh) {
  Grid small = MakeGrid(32, 1.0f), big = MakeGrid(32, 10.0f);
  const float e1 = SimplifyTriangles(small.indices, small.positions, 0.2f).error;
  const float e10 = SimplifyTriangles(big.indices, big.positions, 0.2f).error;
  EXPECT_NEAR(e10 / e1, 10.0f, 0.5f) << "object-space units, not relative";
}

TEST(SimplifyTest, RatioOneKeepsTheInput) {
  const Grid g = MakeGrid(8, 1.0f);
  const SimplifyResult r = SimplifyTriangles(g.indices, g.positions, 1.0f);
  EXPECT_EQ(r.indices, g.indices);
  EXPECT_EQ(r.error, 0.0f);
  EXPECT_EQ(r.method, SimplifyMethod::kNone);
}

// The grid's outline: vertices on x = 0, x = size, z = 0 or z = size.
std::set<uint32_t> BorderVertices(const Grid& g, float size) {
  std::set<uint32_t> border;
  for (size_t v = 0; v < g.positions.size() / 3; ++v) {
    const float x = g.positions[v * 3], z = g.positions[v * 3 + 2];
    if (x == 0.0f || x == size || z == 0.0f || z == size) border.insert(static_cast<uint32_t>(v));
  }
  return border;
}

TEST(SimplifyTest, LockedBorderKeepsEveryBorderVertex) {
  const Grid g = MakeGrid(32, 1.0f);
  const SimplifyResult r = SimplifyTriangles(g.indices, g.positions, 0.5f, {.lock_border = true});
  EXPECT_EQ(r.method, SimplifyMethod::kLockedBorder);
  const std::set<uint32_t> used(r.indices.begin(), r.indices.end());
  for (uint32_t v : BorderVertices(g, 1.0f)) EXPECT_TRUE(used.count(v)) << "border vertex " << v << " removed";
}

TEST(SimplifyTest, DisconnectedCardsReachTheTarget) {
  // 400 separate quads (leaf cards): meshoptimizer 0.18 collapses open
  // borders too, so quadric simplification gets there without sloppy.
  Grid cards;
  for (uint32_t i = 0; i < 400; ++i) {
    const float x = static_cast<float>(i % 20), z = static_cast<float>(i / 20);
    const uint32_t base = static_cast<uint32_t>(cards.positions.size() / 3);
    cards.positions.insert(cards.positions.end(),
                           {x, 0, z, x + 0.5f, 0, z, x, 0.5f, z, x + 0.5f, 0.5f, z});
    cards.indices.insert(cards.indices.end(), {base, base + 1, base + 2, base + 2, base + 1, base + 3});
  }
  const SimplifyResult r = SimplifyTriangles(cards.indices, cards.positions, 0.1f);
  EXPECT_EQ(r.method, SimplifyMethod::kQuadric);
  EXPECT_NEAR(r.indices.size() / 3.0, 80.0, 8.0);
}

}  // namespace
}  // namespace impostor
