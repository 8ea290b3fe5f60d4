#include "worker/surfels/splat_renderer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <glm/geometric.hpp>

#include "worker/surfels/atlas_samples.h"

namespace impostor {

SplatImage RenderSplats(const std::vector<Surfel>& points, float diameter, const FrameCamera& camera,
                        const BoundingSphere& sphere, int size) {
  SplatImage image;
  image.size = size;
  const size_t n = static_cast<size_t>(size) * size;
  image.coverage.assign(n, 0);
  image.albedo.assign(n, glm::vec3(0.0f));
  // Larger = nearer the camera.
  std::vector<float> nearest(n, -std::numeric_limits<float>::infinity());
  const float pixels_per_unit = size / (2.0f * sphere.radius);
  const float half = 0.5f * diameter * pixels_per_unit;
  for (const Surfel& p : points) {
    const glm::vec3 v = p.position - sphere.center;
    const float x = (glm::dot(v, camera.right) / sphere.radius + 1.0f) * 0.5f * size;
    const float y = (1.0f - glm::dot(v, camera.up) / sphere.radius) * 0.5f * size;
    const float depth = glm::dot(v, camera.direction);
    // Pixels whose centre lies in [x - half, x + half), plus the centre's own.
    const int x0 = std::max(0, std::min(static_cast<int>(std::ceil(x - half - 0.5f)), static_cast<int>(std::floor(x))));
    const int x1 = std::min(size - 1, std::max(static_cast<int>(std::ceil(x + half - 0.5f)) - 1, static_cast<int>(std::floor(x))));
    const int y0 = std::max(0, std::min(static_cast<int>(std::ceil(y - half - 0.5f)), static_cast<int>(std::floor(y))));
    const int y1 = std::min(size - 1, std::max(static_cast<int>(std::ceil(y + half - 0.5f)) - 1, static_cast<int>(std::floor(y))));
    for (int py = y0; py <= y1; ++py) {
      for (int px = x0; px <= x1; ++px) {
        const size_t i = static_cast<size_t>(py) * size + px;
        if (depth <= nearest[i]) continue;
        nearest[i] = depth;
        image.coverage[i] = 1;
        image.albedo[i] = p.albedo;
      }
    }
  }
  return image;
}

ViewComparison CompareWithAtlasTile(const SplatImage& image, const AtlasImages& reference, const TileRect& tile) {
  ViewComparison c;
  for (int y = 0; y < image.size; ++y) {
    for (int x = 0; x < image.size; ++x) {
      const size_t i = static_cast<size_t>(y) * image.size + x;
      const size_t r = (static_cast<size_t>(tile.y + y) * reference.width + tile.x + x) * 4;
      const bool splat = image.coverage[i] != 0;
      const bool mesh = reference.albedo_alpha[r + 3] >= 128;
      c.splat_pixels += splat;
      c.reference_pixels += mesh;
      c.either += splat || mesh;
      if (!(splat && mesh)) continue;
      ++c.both;
      for (int a = 0; a < 3; ++a) {
        const double d = image.albedo[i][a] - SrgbByteToLinear(reference.albedo_alpha[r + a]);
        c.albedo_squared_error += d * d;
      }
    }
  }
  return c;
}

double PsnrDb(double mean_squared_error) {
  if (!(mean_squared_error > 1e-10)) return 99.0;
  return 10.0 * std::log10(1.0 / mean_squared_error);
}

std::vector<glm::vec3> HeldOutDirections(int count, bool upper_only) {
  std::vector<glm::vec3> dirs;
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  const double y_min = upper_only ? 0.05 : -1.0;
  for (int i = 0; i < count; ++i) {
    // Heights at the centres of `count` equal bands of [y_min, 1], so no
    // direction is a pole (where frames sit).
    const double y = 1.0 - (i + 0.5) / count * (1.0 - y_min);
    const double ring = std::sqrt(std::max(0.0, 1.0 - y * y));
    const double phi = golden * i + 0.3;
    dirs.push_back(glm::normalize(glm::vec3(static_cast<float>(ring * std::cos(phi)), static_cast<float>(y),
                                            static_cast<float>(ring * std::sin(phi)))));
  }
  return dirs;
}

}  // namespace impostor
