// CPU reference for what a frame of an atlas must cover: rasterises a
// Scene's triangles through a camera rebuilt from the manifest alone
// (direction, up, bounding sphere, tile), sampling pixel centres.
#ifndef IMPOSTOR_TESTS_INTEGRATION_SILHOUETTE_H_
#define IMPOSTOR_TESTS_INTEGRATION_SILHOUETTE_H_

#include <vector>

#include <glm/vec3.hpp>

#include "worker/scene/scene.h"

namespace impostor::testing {

struct ManifestCamera {
  glm::vec3 center;
  float radius;
  glm::vec3 direction;
  glm::vec3 up;
  int tile_width;
  int tile_height;
};

// 1 where some triangle covers the pixel centre, 0 elsewhere; row 0 = top.
std::vector<uint8_t> RasterizeSilhouette(const Scene& scene, const ManifestCamera& camera);

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_INTEGRATION_SILHOUETTE_H_
