#include "common/runtime/virtual_plane.h"

#include <glm/geometric.hpp>

namespace impostor {

glm::vec3 ViewRayOrigin(const FrameCamera& view, glm::vec2 st) {
  return st.x * view.right + st.y * view.up + view.direction;
}

FrameCamera CameraForDirection(glm::vec3 direction) {
  FrameCamera c;
  c.direction = glm::normalize(direction);
  c.up = CameraUpFor(c.direction);
  c.right = glm::normalize(glm::cross(c.up, c.direction));
  return c;
}

PlaneSample IntersectFramePlane(const FrameCamera& frame, glm::vec3 origin, glm::vec3 ray, float height) {
  PlaneSample out;
  const float len = glm::length(ray);
  if (!(len > 0.0f)) return out;
  const glm::vec3 toward_eye = -ray / len;
  const float facing = glm::dot(toward_eye, frame.direction);
  if (!(facing >= 1e-4f)) return out;
  // origin - k * toward_eye lies on the plane dot(q, d) = height.
  const float k = (glm::dot(origin, frame.direction) - height) / facing;
  const glm::vec3 q = origin - k * toward_eye;
  out.valid = true;
  out.st = {glm::dot(q, frame.right), glm::dot(q, frame.up)};
  out.height = height;
  return out;
}

PlaneSample ProjectToFrame(const FrameCamera& view, const FrameCamera& frame, glm::vec2 view_st,
                           float height) {
  return IntersectFramePlane(frame, ViewRayOrigin(view, view_st), -view.direction, height);
}

PlaneSample ProjectToFrameParallax(const FrameCamera& view, const FrameCamera& frame, glm::vec2 view_st,
                                   const FrameHeightReader& read_height) {
  return IntersectFrameHeightField(frame, ViewRayOrigin(view, view_st), -view.direction, read_height);
}

PlaneSample IntersectFrameHeightField(const FrameCamera& frame, glm::vec3 origin, glm::vec3 ray,
                                      const FrameHeightReader& read_height) {
  // True when the ray's point at height h is at or below a covered surface.
  auto below_surface = [&](const PlaneSample& at, float h) {
    float surface = 0.0f;
    return at.valid && read_height(at.st, &surface) && h <= surface;
  };
  float above = 1.0f;  // last height known to be above the surface
  for (int i = 0; i <= kParallaxSteps; ++i) {
    const float h = 1.0f - 2.0f * static_cast<float>(i) / static_cast<float>(kParallaxSteps);
    PlaneSample hit = IntersectFramePlane(frame, origin, ray, h);
    if (!hit.valid) return hit;  // the frame faces away: no height is valid
    if (!below_surface(hit, h)) {
      above = h;
      continue;
    }
    float below = h;
    for (int j = 0; j < kParallaxRefinements && i > 0; ++j) {
      const float mid = 0.5f * (above + below);
      const PlaneSample at = IntersectFramePlane(frame, origin, ray, mid);
      if (below_surface(at, mid)) {
        below = mid;
        hit = at;
      } else {
        above = mid;
      }
    }
    return hit;
  }
  return PlaneSample{};
}

glm::vec2 FrameStToPixel(const TileRect& tile, glm::vec2 st) {
  return {static_cast<float>(tile.x) + (st.x + 1.0f) * 0.5f * static_cast<float>(tile.width),
          static_cast<float>(tile.y) + (1.0f - st.y) * 0.5f * static_cast<float>(tile.height)};
}

}  // namespace impostor
