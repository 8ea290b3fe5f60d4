#include "tests/surfels/mesh_distance.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

namespace impostor::testing {

float DistanceToTriangle(const glm::vec3& p, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
  const glm::vec3 ab = b - a, ac = c - a, ap = p - a;
  const float d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return glm::length(p - a);
  const glm::vec3 bp = p - b;
  const float d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return glm::length(p - b);
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return glm::length(p - (a + ab * (d1 / (d1 - d3))));
  const glm::vec3 cp = p - c;
  const float d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return glm::length(p - c);
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return glm::length(p - (a + ac * (d2 / (d2 - d6))));
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    return glm::length(p - (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)))));
  }
  const float denom = 1.0f / (va + vb + vc);
  return glm::length(p - (a + ab * (vb * denom) + ac * (vc * denom)));
}

float DistanceToMesh(const Scene& scene, const glm::vec3& p) {
  float best = std::numeric_limits<float>::infinity();
  for (size_t i = 0; i + 2 < scene.indices.size(); i += 3) {
    best = std::min(best, DistanceToTriangle(p, scene.vertices[scene.indices[i]].position,
                                             scene.vertices[scene.indices[i + 1]].position,
                                             scene.vertices[scene.indices[i + 2]].position));
  }
  return best;
}

Scene SphereScene(glm::vec3 center, float radius, int rings, glm::vec4 base_color, float roughness,
                  float metalness) {
  Scene s;
  const int segments = 2 * rings;
  for (int i = 0; i <= rings; ++i) {
    const float theta = std::numbers::pi_v<float> * i / rings;
    for (int j = 0; j <= segments; ++j) {
      const float phi = 2.0f * std::numbers::pi_v<float> * j / segments;
      SceneVertex v;
      v.normal = {std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi)};
      v.position = center + radius * v.normal;
      v.uv = {static_cast<float>(j) / segments, static_cast<float>(i) / rings};
      s.vertices.push_back(v);
    }
  }
  for (int i = 0; i < rings; ++i) {
    for (int j = 0; j < segments; ++j) {
      const uint32_t a = i * (segments + 1) + j, b = a + segments + 1;
      // Counter-clockwise seen from outside.
      for (uint32_t k : {a, a + 1, b, a + 1, b + 1, b}) s.indices.push_back(k);
    }
  }
  SceneMaterial m;
  m.base_color_factor = base_color;
  m.roughness_factor = roughness;
  m.metallic_factor = metalness;
  s.materials.push_back(m);
  s.batches.push_back({0, static_cast<uint32_t>(s.indices.size()), 0, false});
  s.bounds_min = center - glm::vec3(radius);
  s.bounds_max = center + glm::vec3(radius);
  return s;
}

}  // namespace impostor::testing
