#include "worker/scene/bounding_sphere.h"

#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>
#include <random>
#include <vector>

namespace impostor {
namespace {

constexpr float kEps = 1e-5f;

void ExpectContainsAll(const BoundingSphere& s, const std::vector<glm::vec3>& points) {
  for (const glm::vec3& p : points) {
    ASSERT_LE(glm::length(p - s.center), s.radius * (1.0f + 1e-6f) + 1e-7f)
        << "point (" << p.x << ", " << p.y << ", " << p.z << ")";
  }
}

TEST(BoundingSphereTest, EmptyAndSinglePoint) {
  EXPECT_EQ(ComputeBoundingSphere(std::vector<glm::vec3>{}).radius, 0.0f);
  const BoundingSphere s = ComputeBoundingSphere(std::vector<glm::vec3>{{1, 2, 3}});
  EXPECT_EQ(s.center, glm::vec3(1, 2, 3));
  EXPECT_EQ(s.radius, 0.0f);
}

TEST(BoundingSphereTest, TwoPoints) {
  const BoundingSphere s = ComputeBoundingSphere(std::vector<glm::vec3>{{-1, 0, 0}, {3, 0, 0}});
  EXPECT_NEAR(s.center.x, 1.0f, kEps);
  EXPECT_NEAR(s.radius, 2.0f, kEps);
}

TEST(BoundingSphereTest, CubeCornersGiveHalfDiagonal) {
  std::vector<glm::vec3> points;
  for (int i = 0; i < 8; ++i) points.emplace_back(i & 1 ? 3 : 1, i & 2 ? 5 : 3, i & 4 ? 2 : 0);
  const BoundingSphere s = ComputeBoundingSphere(points);
  ExpectContainsAll(s, points);
  EXPECT_NEAR(s.radius, std::sqrt(3.0f), kEps);  // half of the 2x2x2 diagonal
  EXPECT_NEAR(glm::length(s.center - glm::vec3(2, 4, 1)), 0.0f, kEps);
}

TEST(BoundingSphereTest, RegularTetrahedron) {
  // Vertices of a regular tetrahedron inscribed in the unit sphere.
  const float a = 1.0f / std::sqrt(3.0f);
  const std::vector<glm::vec3> points = {{a, a, a}, {a, -a, -a}, {-a, a, -a}, {-a, -a, a}};
  const BoundingSphere s = ComputeBoundingSphere(points);
  ExpectContainsAll(s, points);
  EXPECT_NEAR(s.radius, 1.0f, kEps);
  EXPECT_NEAR(glm::length(s.center), 0.0f, kEps);
}

TEST(BoundingSphereTest, ObtuseTriangleUsesItsLongestEdge) {
  // The circumcircle of an obtuse triangle is larger than needed: the
  // minimal sphere has the longest edge as its diameter.
  const std::vector<glm::vec3> points = {{-1, 0, 0}, {1, 0, 0}, {0, 0.1f, 0}};
  const BoundingSphere s = ComputeBoundingSphere(points);
  ExpectContainsAll(s, points);
  EXPECT_NEAR(s.radius, 1.0f, kEps);
}

TEST(BoundingSphereTest, RandomPointsInUnitBall) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<glm::vec3> points;
  while (points.size() < 100000) {
    const glm::vec3 p(u(rng), u(rng), u(rng));
    if (glm::length(p) <= 1.0f) points.push_back(p + glm::vec3(10, -5, 3));
  }
  const BoundingSphere s = ComputeBoundingSphere(points);
  ExpectContainsAll(s, points);
  EXPECT_LE(s.radius, 1.0f + 1e-5f);
  EXPECT_GT(s.radius, 0.99f);  // 100k samples reach close to the surface
}

TEST(BoundingSphereTest, PointsOnASphereAndDuplicates) {
  // Degenerate input for Welzl: everything co-spherical, many duplicates,
  // and coplanar rings.
  std::vector<glm::vec3> points;
  for (int i = 0; i < 2000; ++i) {
    const float t = i * 0.37f, z = std::cos(i * 0.11f);
    const float r = std::sqrt(1 - z * z);
    points.emplace_back(r * std::cos(t) * 5, r * std::sin(t) * 5, z * 5);
    points.push_back(points.back());
    points.emplace_back(std::cos(t) * 5, std::sin(t) * 5, 0.0f);
  }
  const BoundingSphere s = ComputeBoundingSphere(points);
  ExpectContainsAll(s, points);
  EXPECT_NEAR(s.radius, 5.0f, 1e-3f);
}

TEST(BoundingSphereTest, NeverWorseThanTheBoxSphere) {
  std::mt19937 rng(7);
  std::normal_distribution<float> n(0.0f, 1.0f);
  for (int trial = 0; trial < 50; ++trial) {
    std::vector<glm::vec3> points(1 + trial * 13);
    for (glm::vec3& p : points) p = glm::vec3(n(rng) * 3, n(rng), n(rng) * 0.1f);
    glm::vec3 lo = points[0], hi = points[0];
    for (const glm::vec3& p : points) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
    const BoundingSphere s = ComputeBoundingSphere(points);
    ExpectContainsAll(s, points);
    EXPECT_LE(s.radius, glm::length(hi - lo) * 0.5f * (1 + 1e-5f)) << "trial " << trial;
    // Lower bound: half the largest pairwise distance (checked on a sample).
    float diameter = 0;
    for (size_t i = 0; i < points.size(); ++i) {
      for (size_t j = i + 1; j < std::min(points.size(), i + 50); ++j) {
        diameter = std::max(diameter, glm::length(points[i] - points[j]));
      }
    }
    EXPECT_GE(s.radius * (1 + 1e-5f), diameter * 0.5f);
  }
}

TEST(BoundingSphereTest, DeterministicAndIgnoresNonFinite) {
  std::vector<glm::vec3> points = {{0, 0, 0}, {2, 0, 0}, {1, 1, 0}, {1, 0, 1}};
  const BoundingSphere a = ComputeBoundingSphere(points);
  points.push_back(glm::vec3(NAN, 0, 0));
  points.push_back(glm::vec3(INFINITY, 0, 0));
  const BoundingSphere b = ComputeBoundingSphere(points);
  EXPECT_EQ(a.center, b.center);
  EXPECT_EQ(a.radius, b.radius);
}

TEST(BoundingSphereTest, FromScene) {
  Scene scene;
  for (const glm::vec3& p : {glm::vec3(-1, 0, 0), glm::vec3(1, 0, 0)}) {
    SceneVertex v;
    v.position = p;
    scene.vertices.push_back(v);
  }
  const BoundingSphere s = ComputeBoundingSphere(scene);
  EXPECT_NEAR(s.radius, 1.0f, kEps);
}

}  // namespace
}  // namespace impostor
