// Simplification of one triangle primitive to a target triangle count with
// meshoptimizer (Garland & Heckbert, "Surface Simplification Using Quadric
// Error Metrics", SIGGRAPH 1997, as implemented by meshopt_simplify).
//
// Seams: meshopt_simplify welds vertices by position internally and
// classifies a vertex whose position is shared by several vertices (a UV or
// normal seam) as a seam vertex that may only slide along the seam, so the
// index buffer is given as is; no shadow index buffer is needed for that
// (one would weld the seam and smear UVs across it).
//
// Pure functions; thread-safe.
#ifndef IMPOSTOR_WORKER_LOD_LOD_SIMPLIFY_H_
#define IMPOSTOR_WORKER_LOD_LOD_SIMPLIFY_H_

#include <cstdint>
#include <span>
#include <vector>

namespace impostor {

// How a primitive reached its target, coarsest method last.
enum class SimplifyMethod {
  kNone,          // ratio 1: indices kept
  kLockedBorder,  // quadric with borders locked (material boundaries kept)
  kQuadric,       // quadric, borders free
  kWelded,        // quadric over vertices welded by position: attribute
                  // seams (UV, flat normals) no longer block collapses, so
                  // a corner may take a neighbour's UV/normal across a seam
  kSloppy,        // meshopt_simplifySloppy (vertex clustering; topology lost)
};

struct SimplifyOptions {
  // Lock the mesh's open borders: set when they meet another mesh (a piece
  // of the same object), so the two cannot pull apart. When the target
  // cannot be reached with the borders locked they are freed before sloppy
  // simplification is tried.
  bool lock_border = false;
  // A result counts as reaching the target when it has at most
  // target * (1 + tolerance) triangles.
  float tolerance = 0.08f;
  // Vertex ranges welding may not cross: ascending starts, the last entry
  // the vertex count (empty = one range). Keeps each primitive's triangles on
  // its own vertices when several are simplified as one buffer.
  std::span<const uint32_t> weld_ranges;
  // Try meshopt_simplifySloppy when no quadric pass reaches the target.
  // Vertex clustering merges vertices across weld_ranges, so a caller
  // simplifying several primitives as one buffer turns it off and runs the
  // sloppy fallback per primitive.
  bool allow_sloppy = true;
};

struct SimplifyResult {
  std::vector<uint32_t> indices;  // triangle list into the same vertices
  // Geometric error in the units of the positions (meshopt's relative
  // error x meshopt_simplifyScale).
  float error = 0;
  SimplifyMethod method = SimplifyMethod::kNone;
  // The result has at most target * (1 + tolerance) triangles.
  bool reached = false;
};

// Simplifies `indices` (a triangle list, size a multiple of 3) over
// `positions` (xyz per vertex, tightly packed) to about
// round(ratio * triangles) triangles, at least 1. ratio >= 1 returns the
// input with error 0. Passes in order: quadric with locked borders (if
// asked), quadric, quadric over position-welded vertices, sloppy; the first
// to reach the target wins. Quadric results are preferred; the sloppy one is taken
// when no quadric pass reached the target and it is closer to the target
// (by ratio) than the best quadric result. Never returns an empty
// primitive.
SimplifyResult SimplifyTriangles(std::span<const uint32_t> indices, std::span<const float> positions,
                                 float ratio, const SimplifyOptions& options = {});

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_LOD_LOD_SIMPLIFY_H_
