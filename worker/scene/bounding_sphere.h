// Smallest enclosing sphere of a point set, to frame the impostor cameras.
//
// Algorithm: E. Welzl, "Smallest enclosing disks (balls and ellipsoids)",
// in New Results and New Trends in Computer Science, LNCS 555, Springer,
// 1991, pp. 359-370 -- in its iterative form (nested loops over a randomly
// permuted point list, at most 4 support points), which runs in expected
// linear time. The permutation uses a fixed seed, so the result is
// deterministic for a given input (bakes are cached by content).
#ifndef IMPOSTOR_WORKER_SCENE_BOUNDING_SPHERE_H_
#define IMPOSTOR_WORKER_SCENE_BOUNDING_SPHERE_H_

#include <glm/vec3.hpp>
#include <span>

#include "common/atlas/frame_camera.h"
#include "worker/scene/scene.h"

namespace impostor {

// A sphere containing every point of `points` (the returned radius is the
// largest distance from the returned float centre, rounded up), minimal up
// to floating-point rounding (relative ~1e-9 in the search). Empty input gives
// centre 0, radius 0; a single point gives radius 0. Non-finite points are
// ignored. Pure and thread-safe.
BoundingSphere ComputeBoundingSphere(std::span<const glm::vec3> points);

// The same, over all vertex positions of `scene`.
BoundingSphere ComputeBoundingSphere(const Scene& scene);

// Axis-aligned box of the finite vertex positions of `scene`; min > max
// (+inf, -inf) when there are none.
struct BoundingBox {
  glm::vec3 min{0.0f};
  glm::vec3 max{0.0f};
};
BoundingBox ComputeBoundingBox(const Scene& scene);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_SCENE_BOUNDING_SPHERE_H_
