// Test helpers: distances from points to a Scene's triangles (brute force,
// closest point on a triangle after Ericson, "Real-Time Collision
// Detection", 5.1.5), and a UV-sphere Scene with one flat material.
#ifndef IMPOSTOR_TESTS_SURFELS_MESH_DISTANCE_H_
#define IMPOSTOR_TESTS_SURFELS_MESH_DISTANCE_H_

#include <vector>

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "worker/scene/scene.h"

namespace impostor::testing {

// Distance from p to the nearest triangle of `scene`.
float DistanceToMesh(const Scene& scene, const glm::vec3& p);

// Distance from p to triangle (a, b, c).
float DistanceToTriangle(const glm::vec3& p, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c);

// A sphere of `radius` at `center` (`rings` x 2*`rings` quads, outward
// normals, counter-clockwise front faces) with one opaque material of the
// given linear base colour, roughness and metalness.
Scene SphereScene(glm::vec3 center, float radius, int rings, glm::vec4 base_color, float roughness,
                  float metalness);

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_SURFELS_MESH_DISTANCE_H_
