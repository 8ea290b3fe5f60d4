// One mesh level of a LOD chain: every triangle primitive of a LodSource
// simplified to a ratio (worker/lod/lod_simplify) and encoded as .glb
// (worker/lod/lod_glb_writer), with the figures the manifest records.
// Pure function; thread-safe.
#ifndef IMPOSTOR_WORKER_LOD_LOD_LEVELS_H_
#define IMPOSTOR_WORKER_LOD_LOD_LEVELS_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "worker/lod/lod_source.h"

namespace impostor {

struct MeshLevel {
  std::string glb;          // the .glb bytes
  uint64_t triangles = 0;   // drawn by the default scene
  // meshoptimizer's error for the scene simplified as a whole, scene units
  // (measured at each mesh's first node).
  float error = 0;
  bool sloppy = false;      // some primitive needed sloppy simplification
  bool unlocked = false;    // open borders had to be freed to reach the ratio
  bool welded = false;      // attribute seams had to be welded (SimplifyMethod::kWelded)
  // Triangles that would have mixed two primitives' vertices (expected 0).
  uint64_t dropped_triangles = 0;
  double seconds = 0;       // simplify + encode
};

// Builds the level at `ratio` (1 = the original triangles, vertices
// compacted). `texture_files` as LodTextureFileNames. Errors as EncodeLodGlb.
absl::StatusOr<MeshLevel> BuildMeshLevel(const LodSource& source, float ratio,
                                         const std::vector<std::string>& texture_files);

// Every level of a chain: ratios[i] for level i (ratios[0] = 1 for LOD0,
// then decreasing). Each level's `error` is made non-decreasing
// (max(measured, the finer level's)): meshoptimizer's figures for different
// methods (quadric, sloppy) are not on one scale, and a coarser level is
// never assumed better than a finer one; `measured_error` keeps the raw value.
struct ChainLevel {
  MeshLevel mesh;
  float ratio = 1;
  float measured_error = 0;
};
absl::StatusOr<std::vector<ChainLevel>> BuildMeshLevels(const LodSource& source, const std::vector<float>& ratios,
                                                        const std::vector<std::string>& texture_files);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_LOD_LOD_LEVELS_H_
