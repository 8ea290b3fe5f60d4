#include "worker/lod/lod_simplify.h"

#include <meshoptimizer.h>

#include <algorithm>
#include <array>
#include <map>
#include <cmath>
#include <limits>

namespace impostor {
namespace {

// Count-driven simplification: an error limit of the whole mesh extent is
// never the one that stops the collapse. (Not FLT_MAX: meshoptimizer 0.18
// squares it, and the infinity derails meshopt_simplifySloppy's search.)
constexpr float kNoErrorLimit = 1.0f;

}  // namespace

SimplifyResult SimplifyTriangles(std::span<const uint32_t> indices, std::span<const float> positions,
                                 float ratio, const SimplifyOptions& options) {
  SimplifyResult out;
  const size_t triangles = indices.size() / 3;
  if (ratio >= 1.0f || triangles <= 1) {
    out.indices.assign(indices.begin(), indices.end());
    out.reached = true;
    return out;
  }
  const size_t vertex_count = positions.size() / 3;
  const size_t target_triangles = std::max<size_t>(1, static_cast<size_t>(std::lround(ratio * triangles)));
  const size_t target_indices = target_triangles * 3;
  const auto reached = [&](size_t index_count) {
    return index_count > 0 && index_count / 3 <= target_triangles * (1.0 + options.tolerance);
  };
  const float scale = meshopt_simplifyScale(positions.data(), vertex_count, sizeof(float) * 3);

  std::vector<uint32_t> buffer(indices.size());
  float error = 0;
  auto run_quadric = [&](unsigned int flags) {
    const size_t n = meshopt_simplify(buffer.data(), indices.data(), indices.size(), positions.data(), vertex_count,
                                      sizeof(float) * 3, target_indices, kNoErrorLimit, flags, &error);
    return n;
  };

  // The best non-empty result so far, kept should a later pass fail.
  auto keep = [&](size_t n, SimplifyMethod method) {
    if (n == 0) return;
    if (!out.indices.empty() && n >= out.indices.size()) return;
    out.indices.assign(buffer.begin(), buffer.begin() + static_cast<ptrdiff_t>(n));
    out.error = error * scale;
    out.method = method;
  };

  if (options.lock_border) {
    const size_t n = run_quadric(meshopt_SimplifyLockBorder);
    keep(n, SimplifyMethod::kLockedBorder);
    if (reached(n)) {
      out.reached = true;
      return out;
    }
  }
  {
    const size_t n = run_quadric(0);
    keep(n, SimplifyMethod::kQuadric);
    if (reached(n)) {
      out.reached = true;
      return out;
    }
  }
  {
    // Seams everywhere (flat-shaded low-poly meshes: every corner its own
    // normal) leave the seam-preserving quadric stuck; weld by position
    // within each range and try again.
    std::vector<uint32_t> canonical(vertex_count);
    std::vector<uint32_t> ranges(options.weld_ranges.begin(), options.weld_ranges.end());
    if (ranges.size() < 2) ranges = {0, static_cast<uint32_t>(vertex_count)};
    for (size_t r = 0; r + 1 < ranges.size(); ++r) {
      std::map<std::array<float, 3>, uint32_t> first;
      for (uint32_t v = ranges[r]; v < ranges[r + 1] && v < vertex_count; ++v) {
        const std::array<float, 3> key = {positions[v * 3], positions[v * 3 + 1], positions[v * 3 + 2]};
        canonical[v] = first.emplace(key, v).first->second;
      }
    }
    std::vector<uint32_t> welded(indices.size());
    for (size_t i = 0; i < indices.size(); ++i) welded[i] = canonical[indices[i]];
    const size_t n = meshopt_simplify(buffer.data(), welded.data(), welded.size(), positions.data(), vertex_count,
                                      sizeof(float) * 3, target_indices, kNoErrorLimit, 0, &error);
    keep(n, SimplifyMethod::kWelded);
    if (reached(n)) {
      out.reached = true;
      return out;
    }
  }
  if (!options.allow_sloppy) return out;
  // meshopt_simplifySloppy clusters vertices on a grid and may land on
  // either side of the target; it can also drop everything for tiny targets.
  auto run_sloppy = [&](size_t target) {
    return meshopt_simplifySloppy(buffer.data(), indices.data(), indices.size(), positions.data(), vertex_count,
                                  sizeof(float) * 3, target, kNoErrorLimit, &error);
  };
  // Distance from the target as a ratio: sloppy may land well below it.
  const auto miss = [&](size_t index_count) {
    return std::abs(std::log(static_cast<double>(index_count) / static_cast<double>(target_indices)));
  };
  // meshoptimizer 0.18's grid search lands wherever its grid allows, and
  // not monotonically in the target it is given (a 78-triangle target may
  // give 4, 27 or 92): scan targets up to 4x ours for the result closest to
  // ours.
  size_t n = run_sloppy(target_indices), best_target = target_indices;
  if (n < target_indices * 9 / 10 || n > target_indices * 11 / 10) {
    const size_t top = std::min(indices.size(), target_indices * 4);
    constexpr int kSteps = 48;
    for (int step = 1; step <= kSteps; ++step) {
      const size_t t = (target_indices + (top - target_indices) * step / kSteps) / 3 * 3;
      const size_t m = run_sloppy(t);
      if (m > 0 && (n == 0 || miss(m) < miss(n))) {
        n = m;
        best_target = t;
      }
    }
    n = run_sloppy(best_target);
  }
  if (n > 0 && (out.indices.empty() || miss(n) < miss(out.indices.size()))) {
    out.indices.assign(buffer.begin(), buffer.begin() + static_cast<ptrdiff_t>(n));
    out.error = error * scale;
    out.method = SimplifyMethod::kSloppy;
  }
  if (out.indices.empty()) out.indices.assign(indices.begin(), indices.end());
  out.reached = reached(out.indices.size());
  return out;
}

}  // namespace impostor
