// Plane fitting: planar pieces come back exactly, every triangle is
// assigned, and the tolerance holds unless the budget says otherwise.
#include "worker/cards/plane_fitting.h"

#include <cmath>
#include <random>
#include <set>

#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>
#include <gtest/gtest.h>

#include "tests/cards/card_geometry.h"

namespace impostor {
namespace {

using testing::Quad;

glm::vec3 Rotated(glm::vec3 v, float yaw_deg, float pitch_deg) {
  const float y = glm::radians(yaw_deg), p = glm::radians(pitch_deg);
  v = glm::vec3(v.x, v.y * std::cos(p) - v.z * std::sin(p), v.y * std::sin(p) + v.z * std::cos(p));
  return glm::vec3(v.x * std::cos(y) + v.z * std::sin(y), v.y, -v.x * std::sin(y) + v.z * std::cos(y));
}

Quad Turned(Quad q, float yaw, float pitch) {
  q.center = Rotated(q.center, yaw, pitch);
  q.a = Rotated(q.a, yaw, pitch);
  q.b = Rotated(q.b, yaw, pitch);
  return q;
}

struct PlanarCase {
  const char* name;
  std::vector<Quad> quads;
};

std::vector<PlanarCase> PlanarCases() {
  const Quad x_plane{{0.0f, 1.0f, 0.0f}, {0.0f, 0.0f, 1.0f}, {0.0f, 1.0f, 0.0f}, 4};
  const Quad z_plane{{0.0f, 1.0f, 0.3f}, {1.0f, 0.0f, 0.0f}, {0.0f, 1.0f, 0.0f}, 4};
  const Quad y_plane{{0.0f, 0.5f, 0.0f}, {1.0f, 0.0f, 0.0f}, {0.0f, 0.0f, -1.0f}, 3};
  return {
      {"crossed_quads_axis_aligned", {x_plane, z_plane}},
      {"crossed_quads_turned_off_lattice", {Turned(x_plane, 17.3f, 8.1f), Turned(z_plane, 17.3f, 8.1f)}},
      {"three_orthogonal_quads", {x_plane, z_plane, y_plane}},
      {"billboard_x_of_three", {Turned(x_plane, 0.0f, 0.0f), Turned(x_plane, 60.0f, 0.0f), Turned(x_plane, 120.0f, 0.0f)}},
  };
}

TEST(PlaneFitting, PlanarPiecesComeBackExactlyWithZeroError) {
  for (const PlanarCase& c : PlanarCases()) {
    SCOPED_TRACE(c.name);
    const std::vector<Triangle3> soup = testing::Soup(c.quads);
    const PlaneFit fit = FitPlanes(soup, {.max_planes = 8, .tolerance = 0.05f});
    ASSERT_EQ(fit.planes.size(), c.quads.size());
    EXPECT_FALSE(fit.budget_exhausted);
    EXPECT_LT(fit.max_distance, 1e-5f);
    // Each quad's triangles share one plane, distinct per quad, and that
    // plane is the quad's own.
    size_t first = 0;
    std::set<uint32_t> used;
    for (const Quad& q : c.quads) {
      const size_t n = testing::QuadTriangles(q).size();
      const uint32_t plane = fit.triangle_plane[first];
      for (size_t i = first; i < first + n; ++i) ASSERT_EQ(fit.triangle_plane[i], plane) << "triangle " << i;
      EXPECT_TRUE(used.insert(plane).second) << "two quads on one plane";
      const FittedPlane& p = fit.planes[plane];
      const glm::vec3 expected = glm::normalize(glm::cross(q.a, q.b));
      EXPECT_NEAR(glm::dot(p.normal, expected), 1.0f, 1e-6f) << "normal faces the triangles' front";
      EXPECT_NEAR(glm::dot(p.normal, q.center) + p.d, 0.0f, 1e-5f);
      EXPECT_EQ(p.triangles, n);
      EXPECT_LT(p.max_distance, 1e-5f);
      first += n;
    }
  }
}

// A fan of quads around the Y axis, 15 degrees apart: more planes than the
// budget allows at a tight tolerance.
std::vector<Triangle3> Fan(int quads) {
  std::vector<Quad> fan;
  for (int i = 0; i < quads; ++i) {
    fan.push_back(Turned({{0.0f, 1.0f, 0.0f}, {1.0f, 0.0f, 0.0f}, {0.0f, 1.0f, 0.0f}, 2}, 15.0f * i, 0.0f));
  }
  return testing::Soup(fan);
}

void ExpectConsistent(std::span<const Triangle3> soup, const PlaneFit& fit, float tolerance) {
  ASSERT_EQ(fit.triangle_plane.size(), soup.size());
  float worst = 0;
  for (size_t i = 0; i < soup.size(); ++i) {
    ASSERT_LT(fit.triangle_plane[i], fit.planes.size()) << "triangle " << i << " unassigned";
    const FittedPlane& p = fit.planes[fit.triangle_plane[i]];
    EXPECT_NEAR(glm::length(p.normal), 1.0f, 1e-5f);
    const float d = TriangleDistance(soup[i], p.normal, p.d);
    if (!fit.budget_exhausted) {
      EXPECT_LE(d, tolerance * 1.0001f) << "triangle " << i;
    }
    worst = std::max(worst, d);
  }
  EXPECT_FLOAT_EQ(fit.max_distance, worst);
  for (const FittedPlane& p : fit.planes) EXPECT_GT(p.triangles, 0u);
}

TEST(PlaneFitting, BudgetExhaustionIsReportedWithTheResultingError) {
  const std::vector<Triangle3> soup = Fan(12);
  const float tolerance = 0.01f;
  const PlaneFit tight = FitPlanes(soup, {.max_planes = 3, .tolerance = tolerance});
  ExpectConsistent(soup, tight, tolerance);
  EXPECT_EQ(tight.planes.size(), 3u);
  EXPECT_TRUE(tight.budget_exhausted);
  EXPECT_GT(tight.max_distance, tolerance) << "the budget forced triangles off their planes";

  const PlaneFit roomy = FitPlanes(soup, {.max_planes = 64, .tolerance = tolerance});
  ExpectConsistent(soup, roomy, tolerance);
  EXPECT_FALSE(roomy.budget_exhausted);
  EXPECT_EQ(roomy.planes.size(), 12u);
  EXPECT_LT(roomy.max_distance, 1e-5f);
}

TEST(PlaneFitting, EveryTriangleOfARandomSoupIsAssigned) {
  std::mt19937 rng(6);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<Triangle3> soup;
  for (int i = 0; i < 400; ++i) {
    const glm::vec3 c(u(rng), u(rng), u(rng));
    soup.push_back({c, c + 0.1f * glm::vec3(u(rng), u(rng), u(rng)), c + 0.1f * glm::vec3(u(rng), u(rng), u(rng))});
  }
  soup.push_back({glm::vec3(0.2f), glm::vec3(0.2f), glm::vec3(0.2f)});  // degenerate
  for (int budget : {1, 4, 64}) {
    for (float tolerance : {0.001f, 0.05f, 0.5f}) {
      SCOPED_TRACE(::testing::Message() << "budget " << budget << " tolerance " << tolerance);
      const PlaneFit fit = FitPlanes(soup, {.max_planes = budget, .tolerance = tolerance});
      ExpectConsistent(soup, fit, tolerance);
      EXPECT_LE(fit.planes.size(), static_cast<size_t>(budget));
    }
  }
}

TEST(PlaneFitting, EmptyInputHasNoPlanes) {
  const PlaneFit fit = FitPlanes({}, {});
  EXPECT_TRUE(fit.planes.empty());
  EXPECT_TRUE(fit.triangle_plane.empty());
  EXPECT_FALSE(fit.budget_exhausted);
}

}  // namespace
}  // namespace impostor
