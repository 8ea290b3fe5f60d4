// Plane fitting for card clusters ("billboard clouds"): a few planes that
// together hold every triangle of a mesh within a distance tolerance, after
// X. Décoret, F. Durand, F. X. Sillion, J. Dorsey, "Billboard Clouds for
// Extreme Model Simplification", ACM SIGGRAPH 2003 (ACM TOG 22(3)).
//
// As in the paper, plane space is discretised (normal directions x offsets),
// each triangle votes, weighted by its area, for every plane that lies
// within the tolerance of all three of its vertices, and planes are taken
// greedily by support. Departures from the paper, and why:
//   - For one normal a triangle's valid offsets form an interval; offsets are
//     binned at a quarter of the tolerance and a triangle votes for the bins
//     wholly inside its interval (a difference array: linear time per
//     normal), so any offset in a winning bin holds every triangle counted.
//     Tolerances too fine for a bounded grid sweep sorted interval end points
//     instead.
//   - Candidate normals are a Fibonacci lattice over the hemisphere, plus the
//     normals of the largest triangles and of the largest triangle still
//     unassigned: planar pieces are then found exactly even when the
//     tolerance is finer than the lattice, and every round makes progress.
//   - The winning plane is refined by an area-weighted least-squares fit of
//     the triangles it took (kept only when it holds at least as much area
//     within the tolerance), so planar pieces come out with zero error.
//   - Lazy greedy: a normal's best score only falls as triangles are taken,
//     so scores from earlier rounds are upper bounds and most normals are
//     never re-scored.
// When the plane budget runs out first, each remaining triangle goes to the
// plane nearest to it and the result says so (budget_exhausted).
//
// Pure function; thread-safe.
#ifndef IMPOSTOR_WORKER_CARDS_PLANE_FITTING_H_
#define IMPOSTOR_WORKER_CARDS_PLANE_FITTING_H_

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/vec3.hpp>

namespace impostor {

// Three vertices, scene space.
using Triangle3 = std::array<glm::vec3, 3>;

struct PlaneFitOptions {
  // The most planes to return; >= 1.
  int max_planes = 8;
  // How far (scene units) a triangle's vertices may lie from its plane; > 0.
  float tolerance = 0.05f;
  // Candidate normal directions on the hemisphere lattice; 0 = chosen from
  // the tolerance and the mesh extent (finer for tighter tolerances), capped
  // so that the voting stays around 5e7 triangle-normal tests.
  int normal_samples = 0;
};

// A plane dot(normal, p) + d = 0. The normal is unit length and faces the
// side most of the plane's triangles (by area) face.
struct FittedPlane {
  glm::vec3 normal{0.0f, 1.0f, 0.0f};
  float d = 0.0f;
  uint32_t triangles = 0;  // assigned
  // Distance of a triangle = the largest distance of its three vertices
  // from the plane; max and (unweighted) mean over the assigned triangles.
  float max_distance = 0.0f;
  float mean_distance = 0.0f;
};

struct PlaneFit {
  std::vector<FittedPlane> planes;      // in the order they were taken
  std::vector<uint32_t> triangle_plane; // per input triangle, index into planes
  float max_distance = 0.0f;            // over all triangles
  float mean_distance = 0.0f;           // over all triangles
  // True when the budget ran out with triangles left over: they went to
  // their nearest plane, possibly farther than the tolerance.
  bool budget_exhausted = false;
};

// Fits planes to `triangles` (any order; degenerate triangles allowed).
// Every triangle is assigned; with budget_exhausted false, every triangle
// lies within options.tolerance of its plane. An empty input gives no
// planes.
PlaneFit FitPlanes(std::span<const Triangle3> triangles, const PlaneFitOptions& options);

// Largest distance of the triangle's vertices from the plane.
float TriangleDistance(const Triangle3& t, const glm::vec3& normal, float d);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_CARDS_PLANE_FITTING_H_
