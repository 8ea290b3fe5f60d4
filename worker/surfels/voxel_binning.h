// Voxel clustering of surface samples into a budgeted point cloud: the
// samples are binned into an axis-aligned grid, each occupied cell becomes
// one point averaging its samples, and the cell size is found by bisection
// so that the point count is as close as possible to a budget without
// exceeding it. After the Meep engine's VoxelImpostorBaker ("bins every
// opaque pixel into an axis-aligned voxel grid ... The grid resolution is
// tuned iteratively to stay within a point_budget"), itself after the
// voxel representation of Nanite foliage (Epic Games / CD Projekt RED,
// Unreal Fest Stockholm 2025).
//
// Averaging: position, albedo and ORM are plain means over the cell's
// samples (albedo in linear space). Normals are summed after flipping each
// one into the hemisphere of the cell's first sample, then renormalised:
// the two sides of a leaf thinner than a cell carry opposite normals (the
// baker shows a double-sided face's side facing the camera), and a plain sum
// would cancel to noise. Points come out in Morton (Z-) order of their
// cells, so neighbours in the buffer are neighbours in space, which keeps
// GPU caches and per-range culling effective.
//
// Pure functions; thread-safe.
#ifndef IMPOSTOR_WORKER_SURFELS_VOXEL_BINNING_H_
#define IMPOSTOR_WORKER_SURFELS_VOXEL_BINNING_H_

#include <cstddef>
#include <vector>

#include <glm/vec3.hpp>

#include "worker/surfels/surfel.h"

namespace impostor {

// Cells per axis a grid may have: cell coordinates are packed 21 bits each
// into a 63-bit Morton key.
inline constexpr int kMaxCellsPerAxis = 1 << 21;

// Cell (i, j, k) spans origin + [i, i+1) * voxel_size on x, likewise y, z.
struct VoxelGrid {
  glm::vec3 origin{0.0f};
  float voxel_size = 1.0f;  // > 0
};

// Axis-aligned box of the samples' positions (min = max = 0 when empty).
struct SampleBounds {
  glm::vec3 min{0.0f};
  glm::vec3 max{0.0f};
};
SampleBounds BoundsOf(const std::vector<Surfel>& samples);

// Smallest voxel size for which every sample's cell coordinate fits in
// kMaxCellsPerAxis on a grid anchored at bounds.min.
float MinVoxelSizeFor(const SampleBounds& bounds);

// Number of distinct cells the samples fall in. Samples must lie within
// kMaxCellsPerAxis cells of grid.origin on every axis (coordinates clamp).
size_t CountOccupiedCells(const std::vector<Surfel>& samples, const VoxelGrid& grid);

// One point per occupied cell, averaged as described above, in Morton
// order of the cells.
std::vector<Surfel> BinSamples(const std::vector<Surfel>& samples, const VoxelGrid& grid);

struct BudgetFit {
  float voxel_size = 0;
  size_t point_count = 0;  // CountOccupiedCells at voxel_size; <= budget
  int evaluations = 0;     // cell counts computed
  // False when even min_voxel_size gives no more than `budget` points: the
  // capture has too few samples to reach the budget (point_count < budget).
  bool budget_reached = true;
};

// The voxel size in [min_voxel_size, bounds' largest extent] whose cell
// count (grid anchored at the samples' bounds min) is the largest found that
// does not exceed `budget`, by bisection on log(voxel size): at most
// `max_evaluations` counts, stopping early once the count is within
// `tolerance` (a fraction, e.g. 0.002) below the budget. Cell counts fall
// roughly as 1 / size^2 for surfaces; they are not strictly monotonic (the
// grid's alignment shifts), so the best feasible size seen is kept.
// Requires budget >= 1, min_voxel_size > 0 and a non-empty sample set.
BudgetFit FitVoxelSizeToBudget(const std::vector<Surfel>& samples, size_t budget, float min_voxel_size,
                               double tolerance = 0.002, int max_evaluations = 48);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_SURFELS_VOXEL_BINNING_H_
