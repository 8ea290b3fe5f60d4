#include "tests/runtime/synthetic_atlas.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>

#include <glm/geometric.hpp>

namespace impostor::testing {
namespace {

struct Ball {
  glm::vec3 center;  // relative to the bounding sphere, radius units
  float radius;
};

// Both balls lie inside the unit sphere.
constexpr std::array<Ball, 2> kBalls = {{
    {{0.25f, 0.1f, -0.1f}, 0.6f},
    {{-0.45f, -0.3f, 0.35f}, 0.4f},
}};

struct Hit {
  glm::vec3 point;   // radius units, relative to the centre
  glm::vec3 normal;
};

std::optional<Hit> Trace(glm::vec3 origin, glm::vec3 dir) {
  std::optional<Hit> best;
  float best_k = 1e30f;
  for (const Ball& b : kBalls) {
    const glm::vec3 oc = origin - b.center;
    const float half_b = glm::dot(oc, dir);
    const float c = glm::dot(oc, oc) - b.radius * b.radius;
    const float disc = half_b * half_b - c;
    if (disc < 0.0f) continue;
    const float k = -half_b - std::sqrt(disc);
    if (k < 0.0f || k >= best_k) continue;
    best_k = k;
    const glm::vec3 p = origin + k * dir;
    best = Hit{p, glm::normalize(p - b.center)};
  }
  return best;
}

uint8_t Unorm8(float v) { return static_cast<uint8_t>(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f)); }
uint16_t Unorm16(float v) {
  return static_cast<uint16_t>(std::lround(std::clamp(v, 0.0f, 1.0f) * 65535.0f));
}

// Writes one camera's view into a w-stride RGBA image at (x0, y0).
void Render(const FrameCamera& camera, int pixels, int x0, int y0, int stride, uint8_t* albedo,
            uint16_t* normal_depth, uint8_t* orm) {
  for (int y = 0; y < pixels; ++y) {
    for (int x = 0; x < pixels; ++x) {
      const float s = (static_cast<float>(x) + 0.5f) / static_cast<float>(pixels) * 2.0f - 1.0f;
      const float t = 1.0f - (static_cast<float>(y) + 0.5f) / static_cast<float>(pixels) * 2.0f;
      const glm::vec3 origin = s * camera.right + t * camera.up + camera.direction;
      const size_t o = (static_cast<size_t>(y0 + y) * stride + (x0 + x)) * 4;
      const std::optional<Hit> hit = Trace(origin, -camera.direction);
      if (!hit) {
        std::fill_n(albedo + o, 4, 0);
        std::fill_n(orm + o, 4, 0);
        normal_depth[o + 0] = normal_depth[o + 1] = normal_depth[o + 2] = 32768;
        normal_depth[o + 3] = 65535;
        continue;
      }
      const glm::vec3 p = hit->point;
      // Smooth colour bands over the surface: every view differs.
      albedo[o + 0] = Unorm8(0.5f + 0.45f * std::sin(4.0f * p.x + 1.0f));
      albedo[o + 1] = Unorm8(0.5f + 0.45f * std::sin(5.0f * p.y));
      albedo[o + 2] = Unorm8(0.5f + 0.45f * std::cos(3.0f * p.z + 2.0f * p.x));
      albedo[o + 3] = 255;
      const glm::vec3 n = hit->normal * 0.5f + 0.5f;
      normal_depth[o + 0] = Unorm16(n.x);
      normal_depth[o + 1] = Unorm16(n.y);
      normal_depth[o + 2] = Unorm16(n.z);
      normal_depth[o + 3] = Unorm16((1.0f - glm::dot(p, camera.direction)) * 0.5f);
      orm[o + 0] = Unorm8(0.8f + 0.2f * p.y);
      orm[o + 1] = Unorm8(0.5f + 0.4f * p.x);
      orm[o + 2] = Unorm8(p.z > 0.0f ? 1.0f : 0.0f);
      orm[o + 3] = 255;
    }
  }
}

}  // namespace

BoundingSphere SyntheticSphere() { return {glm::vec3(1.0f, 2.0f, -3.0f), 2.5f}; }

ViewImages RenderSyntheticView(const FrameCamera& camera, int pixels) {
  ViewImages v;
  v.width = v.height = pixels;
  const size_t n = static_cast<size_t>(pixels) * pixels * 4;
  v.albedo_alpha.resize(n);
  v.normal_depth.resize(n);
  v.orm.resize(n);
  Render(camera, pixels, 0, 0, pixels, v.albedo_alpha.data(), v.normal_depth.data(), v.orm.data());
  return v;
}

ImpostorAtlas BakeSyntheticAtlas(LayoutKind layout, int frames, int resolution) {
  return BakeSyntheticAtlas(ViewLayout{.kind = layout, .frames = frames}, resolution);
}

ImpostorAtlas BakeSyntheticAtlas(const ViewLayout& layout, int resolution) {
  ImpostorAtlas a;
  a.layout = layout.kind;
  const bool ring = layout.kind == LayoutKind::kRingTop || layout.kind == LayoutKind::kBillboard;
  a.frames = ring ? GridSide(layout) : layout.frames;
  a.ring_views = ring ? layout.ring_views : 0;
  if (layout.kind == LayoutKind::kBillboard) a.ring_views = kBillboardRingViews;
  a.resolution = resolution;
  a.sphere = SyntheticSphere();
  a.cameras = AtlasCameras(layout, resolution);
  a.width = a.height = resolution;
  const size_t n = static_cast<size_t>(resolution) * resolution * 4;
  a.albedo_alpha.assign(n, 0);
  a.normal_depth.assign(n, 0);
  a.orm.assign(n, 0);
  for (size_t i = 0; i < n; i += 4) {
    a.normal_depth[i] = a.normal_depth[i + 1] = a.normal_depth[i + 2] = 32768;
    a.normal_depth[i + 3] = 65535;
  }
  for (const FrameCamera& c : a.cameras) {
    Render(c, c.tile.width, c.tile.x, c.tile.y, resolution, a.albedo_alpha.data(), a.normal_depth.data(),
           a.orm.data());
  }
  return a;
}

ViewImages ExtractTile(const ImpostorAtlas& atlas, int index) {
  const TileRect& t = atlas.cameras[index].tile;
  ViewImages v;
  v.width = t.width;
  v.height = t.height;
  for (int y = 0; y < t.height; ++y) {
    const size_t row = (static_cast<size_t>(t.y + y) * atlas.width + t.x) * 4;
    const size_t len = static_cast<size_t>(t.width) * 4;
    v.albedo_alpha.insert(v.albedo_alpha.end(), atlas.albedo_alpha.begin() + row,
                          atlas.albedo_alpha.begin() + row + len);
    v.normal_depth.insert(v.normal_depth.end(), atlas.normal_depth.begin() + row,
                          atlas.normal_depth.begin() + row + len);
    if (!atlas.orm.empty()) {
      v.orm.insert(v.orm.end(), atlas.orm.begin() + row, atlas.orm.begin() + row + len);
    }
  }
  return v;
}

}  // namespace impostor::testing
