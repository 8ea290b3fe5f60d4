#include "worker/cards/card_rect.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <glm/geometric.hpp>

namespace impostor {
namespace {

float Cross(const glm::vec2& o, const glm::vec2& a, const glm::vec2& b) {
  return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
}

}  // namespace

std::array<glm::vec3, 4> CardRect::Corners() const {
  const glm::vec3 du = u * half_u, dv = v * half_v;
  return {center - du - dv, center + du - dv, center + du + dv, center - du + dv};
}

std::vector<glm::vec2> ConvexHull(std::vector<glm::vec2> p) {
  std::sort(p.begin(), p.end(), [](const glm::vec2& a, const glm::vec2& b) {
    return a.x < b.x || (a.x == b.x && a.y < b.y);
  });
  p.erase(std::unique(p.begin(), p.end()), p.end());
  if (p.size() < 3) return p;
  std::vector<glm::vec2> hull(2 * p.size());
  size_t k = 0;
  for (size_t i = 0; i < p.size(); ++i) {  // lower chain
    while (k >= 2 && Cross(hull[k - 2], hull[k - 1], p[i]) <= 0.0f) --k;
    hull[k++] = p[i];
  }
  for (size_t i = p.size() - 1, lower = k + 1; i-- > 0;) {  // upper chain
    while (k >= lower && Cross(hull[k - 2], hull[k - 1], p[i]) <= 0.0f) --k;
    hull[k++] = p[i];
  }
  hull.resize(k - 1);
  return hull;
}

CardRect MinimalCardRect(std::span<const glm::vec3> points, const glm::vec3& normal, float d) {
  CardRect rect;
  rect.normal = normal;
  // A basis of the plane: e1 from world up (or X for a horizontal plane),
  // e2 = n x e1 so that (e1, e2, n) is right-handed.
  const glm::vec3 seed = std::abs(normal.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
  const glm::vec3 e1 = glm::normalize(seed - normal * glm::dot(normal, seed));
  const glm::vec3 e2 = glm::cross(normal, e1);
  const glm::vec3 origin = -d * normal;
  rect.center = origin;
  rect.u = e1;
  rect.v = e2;
  if (points.empty()) return rect;

  std::vector<glm::vec2> projected;
  projected.reserve(points.size());
  for (const glm::vec3& p : points) projected.emplace_back(glm::dot(p - origin, e1), glm::dot(p - origin, e2));
  std::vector<glm::vec2> hull = ConvexHull(std::move(projected));

  // Candidate directions: every hull edge (a segment's or a point's hull
  // has one or none: then the basis itself).
  std::vector<glm::vec2> directions;
  for (size_t i = 0; i < hull.size() && hull.size() >= 2; ++i) {
    const glm::vec2 edge = hull[(i + 1) % hull.size()] - hull[i];
    const float len = glm::length(edge);
    if (len > 0.0f) directions.push_back(edge / len);
  }
  if (directions.empty()) directions.emplace_back(1.0f, 0.0f);

  float best_area = std::numeric_limits<float>::max();
  for (const glm::vec2& dir : directions) {
    const glm::vec2 perp(-dir.y, dir.x);
    float min_a = std::numeric_limits<float>::max(), max_a = std::numeric_limits<float>::lowest();
    float min_b = min_a, max_b = max_a;
    for (const glm::vec2& h : hull) {
      const float a = glm::dot(h, dir), b = glm::dot(h, perp);
      min_a = std::min(min_a, a);
      max_a = std::max(max_a, a);
      min_b = std::min(min_b, b);
      max_b = std::max(max_b, b);
    }
    const float area = (max_a - min_a) * (max_b - min_b);
    if (area < best_area) {
      best_area = area;
      const glm::vec2 c = dir * (0.5f * (min_a + max_a)) + perp * (0.5f * (min_b + max_b));
      rect.center = origin + e1 * c.x + e2 * c.y;
      rect.u = glm::normalize(e1 * dir.x + e2 * dir.y);
      rect.v = glm::normalize(e1 * perp.x + e2 * perp.y);
      rect.half_u = 0.5f * (max_a - min_a);
      rect.half_v = 0.5f * (max_b - min_b);
    }
  }
  if (rect.half_u < rect.half_v) {  // long side along u; (v, -u, n) stays right-handed
    const glm::vec3 u = rect.u;
    rect.u = rect.v;
    rect.v = -u;
    std::swap(rect.half_u, rect.half_v);
  }
  return rect;
}

}  // namespace impostor
