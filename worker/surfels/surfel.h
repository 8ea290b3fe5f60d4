// One surfel: a sample of a mesh's surface, or one point of a baked surfel
// cloud. Its memory layout is the point buffer's record (12 float32, see
// point_buffer_format.md), so a cloud can be written and handed to a GPU
// instance buffer as-is. Plain data.
#ifndef IMPOSTOR_WORKER_SURFELS_SURFEL_H_
#define IMPOSTOR_WORKER_SURFELS_SURFEL_H_

#include <glm/vec3.hpp>

namespace impostor {

struct Surfel {
  glm::vec3 position{0.0f};  // scene space, scene units
  glm::vec3 normal{0.0f, 1.0f, 0.0f};  // unit, scene space
  glm::vec3 albedo{0.0f};    // linear base colour, 0..1
  glm::vec3 orm{1.0f, 1.0f, 0.0f};  // occlusion, roughness, metalness, 0..1
};
static_assert(sizeof(Surfel) == 12 * sizeof(float), "Surfel is the point buffer's 48-byte record");

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_SURFELS_SURFEL_H_
