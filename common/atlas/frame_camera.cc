#include "common/atlas/frame_camera.h"

#include <cmath>

#include <glm/geometric.hpp>

namespace impostor {

glm::vec3 CameraUpFor(glm::vec3 d) {
  const glm::vec3 world_up(0.0f, 1.0f, 0.0f);
  const glm::vec3 up = world_up - glm::dot(world_up, d) * d;
  // sin(0.01 deg) ~ 1.7e-4: closer to the pole than that, Y is no up vector.
  if (glm::length(up) < 1.7e-4f) return d.y > 0.0f ? glm::vec3(0, 0, -1) : glm::vec3(0, 0, 1);
  return glm::normalize(up);
}

int MipSafeLevels(int resolution, int frames) {
  if (frames <= 0) return 0;
  const int raw = resolution / frames;
  int levels = 0;
  while ((raw >> (levels + 1)) >= kMipSafeTilePixels) ++levels;
  return levels;
}

int TileSize(int resolution, int frames) {
  if (frames <= 0) return 0;
  const int levels = MipSafeLevels(resolution, frames);
  return ((resolution / frames) >> levels) << levels;
}

int BlockAlignedTileSize(int resolution, int frames) {
  if (frames <= 0) return 0;
  const int levels = MipSafeLevels(resolution, frames);
  return ((resolution / frames) >> (levels + 2)) << (levels + 2);
}

std::vector<FrameCamera> AtlasCameras(LayoutKind kind, int frames, int resolution) {
  return AtlasCameras(ViewLayout{.kind = kind, .frames = frames}, resolution);
}

std::vector<FrameCamera> AtlasCameras(const ViewLayout& layout, int resolution) {
  const int tile = TileSize(resolution, GridSide(layout));
  const int count = FrameCount(layout);
  std::vector<FrameCamera> cameras;
  cameras.reserve(static_cast<size_t>(count));
  for (int i = 0; i < count; ++i) {
    FrameCamera c;
    c.index = i;
    c.frame = FrameTile(layout, i);
    c.direction = FrameDirectionAt(layout, i);
    c.up = CameraUpFor(c.direction);
    c.right = glm::normalize(glm::cross(c.up, c.direction));
    c.tile = {c.frame.col * tile, c.frame.row * tile, tile, tile};
    cameras.push_back(c);
  }
  return cameras;
}

glm::mat4 FrameViewProjection(const FrameCamera& camera, const BoundingSphere& sphere) {
  const float inv_r = 1.0f / sphere.radius;
  const glm::vec3& c = sphere.center;
  // Rows of the matrix: x = s, y = -t, z = depth, w = 1 (glm is column-major).
  glm::mat4 m(0.0f);
  auto set_row = [&](int row, glm::vec3 axis, float scale, float offset) {
    m[0][row] = axis.x * scale;
    m[1][row] = axis.y * scale;
    m[2][row] = axis.z * scale;
    m[3][row] = -glm::dot(axis, c) * scale + offset;
  };
  set_row(0, camera.right, inv_r, 0.0f);
  set_row(1, camera.up, -inv_r, 0.0f);
  set_row(2, camera.direction, -0.5f * inv_r, 0.5f);
  m[3][3] = 1.0f;
  return m;
}

}  // namespace impostor
