#include "common/runtime/virtual_plane.h"

#include <glm/geometric.hpp>

namespace impostor {

FrameCamera CameraForDirection(glm::vec3 direction) {
  FrameCamera c;
  c.direction = glm::normalize(direction);
  c.up = CameraUpFor(c.direction);
  c.right = glm::normalize(glm::cross(c.up, c.direction));
  return c;
}

PlaneSample ProjectToFrame(const FrameCamera& view, const FrameCamera& frame, glm::vec2 view_st,
                           float height) {
  return IntersectFramePlane(frame, ViewRayOrigin(view, view_st), -view.direction, height);
}

}  // namespace impostor
