#include "worker/surfels/atlas_samples.h"

#include <array>
#include <cmath>

#include <glm/geometric.hpp>

namespace impostor {
namespace {

const std::array<float, 256>& SrgbTable() {
  static const std::array<float, 256> table = [] {
    std::array<float, 256> t{};
    for (int i = 0; i < 256; ++i) {
      const double c = i / 255.0;
      t[i] = static_cast<float>(c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4));
    }
    return t;
  }();
  return table;
}

}  // namespace

float SrgbByteToLinear(uint8_t code) { return SrgbTable()[code]; }

std::vector<Surfel> AtlasToSamples(const AtlasImages& atlas, const std::vector<FrameCamera>& cameras,
                                   const BoundingSphere& sphere) {
  std::vector<Surfel> samples;
  const auto& srgb = SrgbTable();
  const float r = sphere.radius;
  for (const FrameCamera& cam : cameras) {
    const TileRect& tile = cam.tile;
    if (tile.width <= 0 || tile.height <= 0 || tile.x < 0 || tile.y < 0 || tile.x + tile.width > atlas.width ||
        tile.y + tile.height > atlas.height) {
      continue;
    }
    for (int y = 0; y < tile.height; ++y) {
      const float t = 1.0f - (y + 0.5f) / tile.height * 2.0f;
      for (int x = 0; x < tile.width; ++x) {
        const size_t i = (static_cast<size_t>(tile.y + y) * atlas.width + tile.x + x) * 4;
        if (atlas.albedo_alpha[i + 3] < 128) continue;
        const float s = (x + 0.5f) / tile.width * 2.0f - 1.0f;
        const float depth = atlas.normal_depth[i + 3] / 65535.0f;
        Surfel p;
        p.position = sphere.center + r * (s * cam.right + t * cam.up + (1.0f - 2.0f * depth) * cam.direction);
        const glm::vec3 n(atlas.normal_depth[i] / 65535.0f * 2.0f - 1.0f,
                          atlas.normal_depth[i + 1] / 65535.0f * 2.0f - 1.0f,
                          atlas.normal_depth[i + 2] / 65535.0f * 2.0f - 1.0f);
        const float len = glm::length(n);
        // A degenerate normal (never written by the baker) faces the camera.
        p.normal = len > 1e-6f ? n / len : cam.direction;
        p.albedo = {srgb[atlas.albedo_alpha[i]], srgb[atlas.albedo_alpha[i + 1]], srgb[atlas.albedo_alpha[i + 2]]};
        p.orm = {atlas.orm[i] / 255.0f, atlas.orm[i + 1] / 255.0f, atlas.orm[i + 2] / 255.0f};
        samples.push_back(p);
      }
    }
  }
  return samples;
}

}  // namespace impostor
