// Card rectangles (minimal area, not axis-aligned by accident) and their
// packing into the card atlas.
#include "worker/cards/card_rect.h"

#include <cmath>

#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>
#include <gtest/gtest.h>

#include "worker/cards/card_packing.h"

namespace impostor {
namespace {

TEST(CardRect, MinimalRectangleOfARotatedRectangleIsThatRectangle) {
  const glm::vec3 n = glm::normalize(glm::vec3(0.3f, 0.8f, -0.5f));
  const float d = -0.7f;
  // An in-plane frame, then a 3 x 1 rectangle turned by 27 degrees in it.
  const glm::vec3 e1 = glm::normalize(glm::cross(n, glm::vec3(1, 0, 0)));
  const glm::vec3 e2 = glm::cross(n, e1);
  const float angle = glm::radians(27.0f);
  const glm::vec3 a = std::cos(angle) * e1 + std::sin(angle) * e2, b = glm::cross(n, a);
  const glm::vec3 c = -d * n + 0.4f * e1 - 1.1f * e2;
  std::vector<glm::vec3> points = {c - 1.5f * a - 0.5f * b, c + 1.5f * a - 0.5f * b, c + 1.5f * a + 0.5f * b,
                                   c - 1.5f * a + 0.5f * b};
  for (int i = 0; i < 20; ++i) {  // interior points, some off the plane
    points.push_back(c + (0.07f * i - 0.7f) * a + (0.04f * i - 0.4f) * b + 0.01f * (i % 3) * n);
  }
  const CardRect r = MinimalCardRect(points, n, d);
  EXPECT_NEAR(r.Area(), 3.0f, 1e-4f);
  EXPECT_NEAR(r.half_u, 1.5f, 1e-4f);
  EXPECT_NEAR(r.half_v, 0.5f, 1e-4f);
  EXPECT_NEAR(std::abs(glm::dot(r.u, a)), 1.0f, 1e-5f) << "long side along the rectangle's";
  EXPECT_NEAR(glm::dot(glm::cross(r.u, r.v), n), 1.0f, 1e-5f) << "(u, v, n) right-handed";
  EXPECT_NEAR(glm::dot(n, r.center) + d, 0.0f, 1e-5f);
  for (const glm::vec3& corner : r.Corners()) {
    float nearest = 1e9f;
    for (int k = 0; k < 4; ++k) nearest = std::min(nearest, glm::length(corner - points[k]));
    EXPECT_LT(nearest, 1e-4f);
  }
  // Counter-clockwise seen from the normal.
  const auto k = r.Corners();
  EXPECT_GT(glm::dot(glm::cross(k[1] - k[0], k[2] - k[0]), n), 0.0f);
}

TEST(CardRect, ConvexHullDropsInteriorAndCollinearPoints) {
  const std::vector<glm::vec2> hull =
      ConvexHull({{0, 0}, {1, 0}, {2, 0}, {2, 2}, {0, 2}, {1, 1}, {0.5f, 1.5f}, {0, 1}});
  EXPECT_EQ(hull.size(), 4u);
}

TEST(CardPacking, UniformDensityNoOverlapInsideTheAtlas) {
  std::vector<CardRect> cards(5);
  const float sizes[5][2] = {{1.0f, 1.0f}, {2.0f, 1.0f}, {0.5f, 0.25f}, {3.0f, 0.2f}, {0.0f, 0.0f}};
  for (int i = 0; i < 5; ++i) {
    cards[i].half_u = sizes[i][0] / 2;
    cards[i].half_v = sizes[i][1] / 2;
  }
  auto p = PackCards(cards, 256);
  ASSERT_TRUE(p.ok()) << p.status();
  ASSERT_EQ(p->tiles.size(), 5u);
  EXPECT_EQ(p->gutter, 2);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(p->tiles[i].width, std::max(1, static_cast<int>(std::ceil(sizes[i][0] * p->texels_per_unit - 1e-3f))));
    const TileRect& a = p->tiles[i];
    EXPECT_GE(a.x - p->gutter, 0);
    EXPECT_GE(a.y - p->gutter, 0);
    EXPECT_LE(a.x + a.width + p->gutter, 256);
    EXPECT_LE(a.y + a.height + p->gutter, 256);
    for (int j = 0; j < i; ++j) {
      const TileRect& b = p->tiles[j];
      const bool apart = a.x + a.width + p->gutter <= b.x - p->gutter || b.x + b.width + p->gutter <= a.x - p->gutter ||
                         a.y + a.height + p->gutter <= b.y - p->gutter || b.y + b.height + p->gutter <= a.y - p->gutter;
      EXPECT_TRUE(apart) << "cards " << i << " and " << j << " overlap with their gutters";
    }
  }
  EXPECT_GT(p->texels_per_unit, 256.0f / 8.0f) << "the atlas is used, not left mostly empty";
}

TEST(CardPacking, TooManyCardsForTheAtlasIsRefused) {
  std::vector<CardRect> cards(4);
  auto p = PackCards(cards, 8);
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(p.status().message().find("4 cards"), std::string::npos) << p.status();
}

}  // namespace
}  // namespace impostor
