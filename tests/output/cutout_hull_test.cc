#include "worker/output/cutout_hull.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

namespace impostor {
namespace {

using Mask = std::vector<uint8_t>;

// Whether (x, y) lies inside or on the convex polygon (tile units).
bool Contains(const CutoutPolygon& poly, glm::vec2 p) {
  const size_t n = poly.vertices.size();
  for (size_t i = 0; i < n; ++i) {
    const glm::vec2 a = poly.vertices[i], b = poly.vertices[(i + 1) % n];
    // Counter-clockwise as displayed (y down) = clockwise in y-up maths:
    // inside is to the right of every edge, cross <= 0.
    const float cross = (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
    if (cross > 1e-5f) return false;
  }
  return true;
}

void ExpectContainsEveryTexel(const CutoutPolygon& poly, const Mask& mask, int size) {
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      if (!mask[static_cast<size_t>(y) * size + x]) continue;
      for (glm::vec2 corner : {glm::vec2(x, y), glm::vec2(x + 1, y), glm::vec2(x, y + 1), glm::vec2(x + 1, y + 1)}) {
        ASSERT_TRUE(Contains(poly, corner / static_cast<float>(size))) << "texel " << x << "," << y;
      }
    }
  }
}

double SignedAreaYDown(const CutoutPolygon& poly) {
  double a = 0;
  for (size_t i = 0; i < poly.vertices.size(); ++i) {
    const glm::vec2 p = poly.vertices[i], q = poly.vertices[(i + 1) % poly.vertices.size()];
    a += p.x * q.y - q.x * p.y;
  }
  return a * 0.5;
}

Mask Disc(int size, float cx, float cy, float r) {
  Mask m(static_cast<size_t>(size) * size, 0);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x)
      m[static_cast<size_t>(y) * size + x] = std::hypot(x + 0.5f - cx, y + 0.5f - cy) <= r;
  return m;
}

TEST(CutoutHull, DiscGetsAnOctagonThatHoldsEveryTexel) {
  const int size = 128;
  const Mask disc = Disc(size, 64, 64, 40);
  const CutoutPolygon poly = CutoutFromMask(disc, size, size, 8);
  EXPECT_LE(poly.vertices.size(), 8u);
  EXPECT_GE(poly.vertices.size(), 3u);
  ExpectContainsEveryTexel(poly, disc, size);
  // A disc of radius 40 covers 0.307 of the tile; its circumscribed octagon
  // 0.318. The cutout is close to that, far below the quad's 1.
  EXPECT_GT(poly.area_ratio, 0.30f);
  EXPECT_LT(poly.area_ratio, 0.36f);
  EXPECT_LT(SignedAreaYDown(poly), 0.0) << "vertices must run counter-clockwise as displayed";
  for (glm::vec2 v : poly.vertices) {
    EXPECT_GE(v.x, 0.0f);
    EXPECT_LE(v.x, 1.0f);
    EXPECT_GE(v.y, 0.0f);
    EXPECT_LE(v.y, 1.0f);
  }
}

TEST(CutoutHull, FewerVerticesCostArea) {
  const int size = 96;
  const Mask disc = Disc(size, 40, 52, 30);
  float last = 0.0f;
  for (int k : {16, 8, 6, 4}) {
    const CutoutPolygon poly = CutoutFromMask(disc, size, size, k);
    EXPECT_LE(static_cast<int>(poly.vertices.size()), k);
    ExpectContainsEveryTexel(poly, disc, size);
    EXPECT_GE(poly.area_ratio, last - 1e-6f) << k << " vertices";
    last = poly.area_ratio;
  }
}

TEST(CutoutHull, RectangleIsExact) {
  const int size = 64;
  Mask m(static_cast<size_t>(size) * size, 0);
  for (int y = 10; y < 30; ++y)
    for (int x = 5; x < 45; ++x) m[static_cast<size_t>(y) * size + x] = 1;
  const CutoutPolygon poly = CutoutFromMask(m, size, size, 8);
  ASSERT_EQ(poly.vertices.size(), 4u);
  EXPECT_NEAR(poly.area_ratio, 40.0 * 20.0 / (64.0 * 64.0), 1e-6);
}

TEST(CutoutHull, TouchingTheTileEdgesFallsBackNoFurtherThanTheTile) {
  // A plus sign touching all four edges: any simplification to 4 vertices
  // inside the tile is the tile itself.
  const int size = 32;
  Mask m(static_cast<size_t>(size) * size, 0);
  for (int i = 0; i < size; ++i) {
    m[static_cast<size_t>(16) * size + i] = 1;
    m[static_cast<size_t>(i) * size + 16] = 1;
  }
  const CutoutPolygon poly = CutoutFromMask(m, size, size, 4);
  ASSERT_EQ(poly.vertices.size(), 4u);
  ExpectContainsEveryTexel(poly, m, size);
  for (glm::vec2 v : poly.vertices) {
    EXPECT_GE(v.x, 0.0f);
    EXPECT_LE(v.y, 1.0f);
  }
}

TEST(CutoutHull, EmptyMaskIsTheWholeTile) {
  const Mask m(16 * 16, 0);
  const CutoutPolygon poly = CutoutFromMask(m, 16, 16, 8);
  EXPECT_EQ(poly.vertices.size(), 4u);
  EXPECT_FLOAT_EQ(poly.area_ratio, 1.0f);
}

TEST(CutoutHull, UnionOfAllTiles) {
  // Two 8x8 tiles side by side: a texel at (1,1) in one, (6,6) in the other.
  const int w = 16, h = 8;
  std::vector<uint8_t> rgba(static_cast<size_t>(w) * h * 4, 0);
  rgba[(1 * w + 1) * 4 + 3] = 255;
  rgba[(6 * w + 8 + 6) * 4 + 3] = 255;
  const TileRect tiles[] = {{0, 0, 8, 8}, {8, 0, 8, 8}};
  auto poly = ComputeCutout(rgba, w, h, tiles, 8);
  ASSERT_TRUE(poly.ok()) << poly.status();
  Mask both(64, 0);
  both[1 * 8 + 1] = both[6 * 8 + 6] = 1;
  ExpectContainsEveryTexel(*poly, both, 8);
  EXPECT_LT(poly->area_ratio, 1.0f);
}

TEST(CutoutHull, BadInputIsRefused) {
  std::vector<uint8_t> rgba(16 * 16 * 4, 0);
  const TileRect ok[] = {{0, 0, 8, 8}};
  const TileRect outside[] = {{10, 10, 8, 8}};
  const TileRect mixed[] = {{0, 0, 8, 8}, {8, 0, 4, 4}};
  EXPECT_EQ(ComputeCutout(rgba, 16, 15, ok).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ComputeCutout(rgba, 16, 16, outside).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ComputeCutout(rgba, 16, 16, mixed).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ComputeCutout(rgba, 16, 16, ok, 3).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ComputeCutout(rgba, 16, 16, {}).status().code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace impostor
