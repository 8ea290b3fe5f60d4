#include "worker/lod/lod_levels.h"

#include <algorithm>
#include <chrono>
#include <span>

#include <glm/vec4.hpp>

#include "worker/lod/lod_glb_writer.h"
#include "worker/lod/lod_simplify.h"

namespace impostor {

absl::StatusOr<MeshLevel> BuildMeshLevel(const LodSource& source, float ratio,
                                         const std::vector<std::string>& texture_files) {
  const auto clock_start = std::chrono::steady_clock::now();
  MeshLevel level;
  // The whole drawn scene is simplified as one index buffer over every
  // primitive's vertices laid end to end, in scene space (each mesh placed by
  // its first node):
  //  * one triangle budget for the scene, spent where it costs the least
  //    error, so a 4-triangle label is not halved like a 40k-triangle body;
  //  * one greedy collapse sequence, so the error grows with every level and
  //    comes out in scene units directly;
  //  * material boundaries and meshes that touch are the same position in
  //    two vertex ranges: meshoptimizer welds by position and treats them as
  //    seams, which stay in place, without locking them.
  // Open borders (silhouette edges, cut-outs) are locked on the first pass
  // (meshopt_SimplifyLockBorder) and freed only when the target cannot be
  // reached with them locked (leaf cards are all border).
  std::vector<uint32_t> start(source.primitives.size() + 1, 0);
  std::vector<float> positions;
  std::vector<uint32_t> merged;
  for (size_t k = 0; k < source.primitives.size(); ++k) {
    const LodPrimitive& prim = source.primitives[k];
    const glm::mat4& world = source.mesh_world[prim.mesh];
    const uint32_t base = static_cast<uint32_t>(positions.size() / 3);
    start[k] = base;
    for (size_t v = 0; v + 2 < prim.positions.size(); v += 3) {
      const glm::vec4 p = world * glm::vec4(prim.positions[v], prim.positions[v + 1], prim.positions[v + 2], 1.0f);
      positions.insert(positions.end(), {p.x, p.y, p.z});
    }
    for (uint32_t i : prim.indices) merged.push_back(base + i);
  }
  start.back() = static_cast<uint32_t>(positions.size() / 3);
  SimplifyResult r = SimplifyTriangles(merged, positions, ratio,
                                       {.lock_border = true, .weld_ranges = start, .allow_sloppy = false});
  level.error = r.error;
  level.unlocked = r.method == SimplifyMethod::kQuadric;
  level.welded = r.method == SimplifyMethod::kWelded;
  if (!r.reached) {
    // Sloppy fallback per primitive (scene-space positions, its own range),
    // each to the same ratio.
    level.sloppy = true;
    level.error = 0;
    r.indices.clear();
    for (size_t k = 0; k < source.primitives.size(); ++k) {
      const std::span<const float> p(positions.data() + size_t{start[k]} * 3,
                                     size_t{start[k + 1] - start[k]} * 3);
      const SimplifyResult part = SimplifyTriangles(source.primitives[k].indices, p, ratio,
                                                    {.lock_border = true, .weld_ranges = {}});
      level.error = std::max(level.error, part.error);
      for (uint32_t i : part.indices) r.indices.push_back(start[k] + i);
    }
  }
  // Split the triangles back by the vertex range they lie in. Collapses keep
  // a seam's sides apart, so a triangle should never span two ranges; one
  // that does is dropped rather than written with foreign indices.
  std::vector<std::vector<uint32_t>> indices(source.primitives.size());
  for (size_t t = 0; t + 2 < r.indices.size(); t += 3) {
    const uint32_t a = r.indices[t], b = r.indices[t + 1], c = r.indices[t + 2];
    const size_t k = std::upper_bound(start.begin(), start.end(), a) - start.begin() - 1;
    if (b < start[k] || b >= start[k + 1] || c < start[k] || c >= start[k + 1]) {
      ++level.dropped_triangles;
      continue;
    }
    indices[k].insert(indices[k].end(), {a - start[k], b - start[k], c - start[k]});
  }
  std::vector<size_t> counts;
  for (const auto& i : indices) counts.push_back(i.size());
  level.triangles = source.DrawnTriangles(counts);
  auto glb = EncodeLodGlb(source, indices, texture_files);
  if (!glb.ok()) return glb.status();
  level.glb = std::move(*glb);
  level.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - clock_start).count();
  return level;
}

absl::StatusOr<std::vector<ChainLevel>> BuildMeshLevels(const LodSource& source, const std::vector<float>& ratios,
                                                        const std::vector<std::string>& texture_files) {
  std::vector<ChainLevel> levels;
  float previous = 0;
  for (float ratio : ratios) {
    auto built = BuildMeshLevel(source, ratio, texture_files);
    if (!built.ok()) return built.status();
    ChainLevel level{.mesh = std::move(*built), .ratio = ratio};
    level.measured_error = level.mesh.error;
    level.mesh.error = std::max(level.mesh.error, previous);
    previous = level.mesh.error;
    levels.push_back(std::move(level));
  }
  return levels;
}

}  // namespace impostor
