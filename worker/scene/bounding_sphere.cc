#include "worker/scene/bounding_sphere.h"

#include <algorithm>
#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <limits>
#include <random>
#include <vector>

namespace impostor {
namespace {

using glm::dvec3;

struct Ball {
  dvec3 center{0.0};
  double radius = 0.0;
};

// Relative slack of the "is inside" test. Without it, rounding makes
// support points test as outside their own sphere and the loops redo work.
constexpr double kRelativeSlack = 1e-9;

Ball Ball2(const dvec3& a, const dvec3& b) { return {(a + b) * 0.5, glm::length(a - b) * 0.5}; }

// Sphere with a, b, c on its surface and its centre in their plane (their
// circumcircle); the farthest pair's sphere when they are collinear.
Ball Ball3(const dvec3& a, const dvec3& b, const dvec3& c) {
  const dvec3 ab = b - a, ac = c - a;
  const dvec3 n = glm::cross(ab, ac);
  const double n2 = glm::dot(n, n);
  const double ab2 = glm::dot(ab, ab), ac2 = glm::dot(ac, ac);
  if (n2 <= 1e-24 * ab2 * ac2 || n2 == 0.0) {
    Ball best = Ball2(a, b);
    for (const Ball& other : {Ball2(a, c), Ball2(b, c)}) {
      if (other.radius > best.radius) best = other;
    }
    return best;
  }
  const dvec3 offset = (ac2 * glm::cross(n, ab) + ab2 * glm::cross(ac, n)) / (2.0 * n2);
  return {a + offset, glm::length(offset)};
}

bool Inside(const Ball& ball, const dvec3& p, double scale) {
  return glm::length(p - ball.center) <= ball.radius + kRelativeSlack * scale;
}

// Sphere with a, b, c, d on its surface (their circumsphere). For coplanar
// points, the smallest circumcircle sphere of three of them that contains
// the fourth.
Ball Ball4(const dvec3& a, const dvec3& b, const dvec3& c, const dvec3& d, double scale) {
  const dvec3 ab = b - a, ac = c - a, ad = d - a;
  const double det = glm::dot(ab, glm::cross(ac, ad));
  const double size = glm::length(ab) * glm::length(ac) * glm::length(ad);
  if (std::abs(det) > 1e-12 * size && size > 0.0) {
    // Solve [ab; ac; ad] x = 0.5 * (|ab|^2, |ac|^2, |ad|^2) by Cramer's rule.
    const dvec3 x =
        (0.5 * glm::dot(ab, ab) * glm::cross(ac, ad) + 0.5 * glm::dot(ac, ac) * glm::cross(ad, ab) +
         0.5 * glm::dot(ad, ad) * glm::cross(ab, ac)) /
        det;
    return {a + x, glm::length(x)};
  }
  const Ball candidates[] = {Ball3(a, b, c), Ball3(a, b, d), Ball3(a, c, d), Ball3(b, c, d)};
  const dvec3 others[] = {d, c, b, a};
  Ball best{dvec3(0.0), -1.0};
  Ball largest = candidates[0];
  for (int i = 0; i < 4; ++i) {
    if (candidates[i].radius > largest.radius) largest = candidates[i];
    if (Inside(candidates[i], others[i], scale) &&
        (best.radius < 0.0 || candidates[i].radius < best.radius)) {
      best = candidates[i];
    }
  }
  return best.radius >= 0.0 ? best : largest;
}

}  // namespace

BoundingSphere ComputeBoundingSphere(std::span<const glm::vec3> points) {
  std::vector<dvec3> p;
  p.reserve(points.size());
  double scale = 0.0;  // largest coordinate magnitude, for the slack
  for (const glm::vec3& v : points) {
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) continue;
    p.emplace_back(v);
    scale = std::max({scale, std::abs(double(v.x)), std::abs(double(v.y)), std::abs(double(v.z))});
  }
  if (p.empty()) return {};
  // Expected linear time needs a random order; a fixed seed keeps the
  // result reproducible. std::shuffle's algorithm is unspecified, so the
  // Fisher-Yates loop is spelled out (same order on every standard library).
  std::mt19937_64 rng(0x5eed5eed1234abcdULL);
  for (size_t i = p.size() - 1; i > 0; --i) {
    std::swap(p[i], p[rng() % (i + 1)]);
  }

  Ball ball{p[0], 0.0};
  for (size_t i = 1; i < p.size(); ++i) {
    if (Inside(ball, p[i], scale)) continue;
    ball = {p[i], 0.0};
    for (size_t j = 0; j < i; ++j) {
      if (Inside(ball, p[j], scale)) continue;
      ball = Ball2(p[i], p[j]);
      for (size_t k = 0; k < j; ++k) {
        if (Inside(ball, p[k], scale)) continue;
        ball = Ball3(p[i], p[j], p[k]);
        for (size_t l = 0; l < k; ++l) {
          if (Inside(ball, p[l], scale)) continue;
          ball = Ball4(p[i], p[j], p[k], p[l], scale);
        }
      }
    }
  }

  // The caller gets floats: measure every point against the rounded centre
  // and round the radius up, so containment holds exactly in float terms.
  BoundingSphere out;
  out.center = glm::vec3(ball.center);
  const dvec3 center(out.center);
  double radius = 0.0;
  for (const dvec3& q : p) radius = std::max(radius, glm::length(q - center));
  out.radius = radius > 0.0 ? std::nextafter(static_cast<float>(radius), INFINITY) : 0.0f;
  return out;
}

BoundingSphere ComputeBoundingSphere(const Scene& scene) {
  std::vector<glm::vec3> positions;
  positions.reserve(scene.vertices.size());
  for (const SceneVertex& v : scene.vertices) positions.push_back(v.position);
  return ComputeBoundingSphere(positions);
}

BoundingBox ComputeBoundingBox(const Scene& scene) {
  BoundingBox box{glm::vec3(std::numeric_limits<float>::infinity()),
                  glm::vec3(-std::numeric_limits<float>::infinity())};
  for (const SceneVertex& v : scene.vertices) {
    if (!std::isfinite(v.position.x) || !std::isfinite(v.position.y) || !std::isfinite(v.position.z)) continue;
    box.min = glm::min(box.min, v.position);
    box.max = glm::max(box.max, v.position);
  }
  return box;
}

}  // namespace impostor
