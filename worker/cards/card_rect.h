// The card of a fitted plane: the minimal-area rectangle, in the plane,
// bounding its triangles projected onto it. The hull of the projected
// vertices (Andrew's monotone chain) is measured along each of its edge
// directions (rotating calipers: Freeman & Shapira, "Determining the
// minimum-area encasing rectangle for an arbitrary closed curve", CACM 18(7),
// 1975, which shows an optimal rectangle has a side on a hull edge).
//
// Pure functions; thread-safe.
#ifndef IMPOSTOR_WORKER_CARDS_CARD_RECT_H_
#define IMPOSTOR_WORKER_CARDS_CARD_RECT_H_

#include <array>
#include <span>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

namespace impostor {

// A rectangle in a plane: centre + s * half_u * u + t * half_v * v for
// s, t in [-1, 1]. (u, v, normal) is a right-handed orthonormal frame, and
// half_u >= half_v (the long side along u).
struct CardRect {
  glm::vec3 center{0.0f};
  glm::vec3 u{1.0f, 0.0f, 0.0f};
  glm::vec3 v{0.0f, 1.0f, 0.0f};
  glm::vec3 normal{0.0f, 0.0f, 1.0f};
  float half_u = 0.0f;
  float half_v = 0.0f;

  // Corners counter-clockwise seen from the normal's side, starting at
  // (-u, -v): (-,-), (+,-), (+,+), (-,+).
  std::array<glm::vec3, 4> Corners() const;
  float Area() const { return 4.0f * half_u * half_v; }
};

// Convex hull of 2D points, counter-clockwise, no collinear points; fewer
// than 3 points for degenerate input.
std::vector<glm::vec2> ConvexHull(std::vector<glm::vec2> points);

// Minimal-area rectangle in the plane (unit `normal`, offset `d`: dot(n, p)
// + d = 0) holding every point of `points` projected onto the plane. The
// centre lies on the plane. Empty input: a zero rectangle at the plane's
// point nearest the origin.
CardRect MinimalCardRect(std::span<const glm::vec3> points, const glm::vec3& normal, float d);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_CARDS_CARD_RECT_H_
