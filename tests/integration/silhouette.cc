#include "tests/integration/silhouette.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>

namespace impostor::testing {

std::vector<uint8_t> RasterizeSilhouette(const Scene& scene, const ManifestCamera& cam) {
  const int w = cam.tile_width, h = cam.tile_height;
  std::vector<uint8_t> mask(static_cast<size_t>(w) * h, 0);
  const glm::vec3 right = glm::normalize(glm::cross(cam.up, cam.direction));
  auto project = [&](const glm::vec3& p) {
    const glm::vec3 d = p - cam.center;
    const float s = glm::dot(d, right) / cam.radius;
    const float t = glm::dot(d, cam.up) / cam.radius;
    return glm::vec2((s + 1.0f) * 0.5f * w, (1.0f - t) * 0.5f * h);
  };
  for (size_t i = 0; i + 2 < scene.indices.size(); i += 3) {
    const glm::vec2 a = project(scene.vertices[scene.indices[i]].position);
    const glm::vec2 b = project(scene.vertices[scene.indices[i + 1]].position);
    const glm::vec2 c = project(scene.vertices[scene.indices[i + 2]].position);
    const float area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if (area == 0.0f) continue;
    const int x0 = std::max(0, static_cast<int>(std::floor(std::min({a.x, b.x, c.x}))));
    const int x1 = std::min(w - 1, static_cast<int>(std::ceil(std::max({a.x, b.x, c.x}))));
    const int y0 = std::max(0, static_cast<int>(std::floor(std::min({a.y, b.y, c.y}))));
    const int y1 = std::min(h - 1, static_cast<int>(std::ceil(std::max({a.y, b.y, c.y}))));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const glm::vec2 p(x + 0.5f, y + 0.5f);
        const float e0 = (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
        const float e1 = (c.x - b.x) * (p.y - b.y) - (c.y - b.y) * (p.x - b.x);
        const float e2 = (a.x - c.x) * (p.y - c.y) - (a.y - c.y) * (p.x - c.x);
        const bool inside = area > 0 ? (e0 >= 0 && e1 >= 0 && e2 >= 0) : (e0 <= 0 && e1 <= 0 && e2 <= 0);
        if (inside) mask[static_cast<size_t>(y) * w + x] = 1;
      }
    }
  }
  return mask;
}

}  // namespace impostor::testing
