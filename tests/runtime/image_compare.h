// Small image comparisons for the runtime tests (the quality pass has its
// own metrics; these stay independent so the tests check the renderer, not
// the metrics).
#ifndef IMPOSTOR_TESTS_RUNTIME_IMAGE_COMPARE_H_
#define IMPOSTOR_TESTS_RUNTIME_IMAGE_COMPARE_H_

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "common/runtime/reference_renderer.h"

namespace impostor::testing {

struct Comparison {
  double iou = 0.0;               // coverage (alpha >= 128) intersection / union
  int coverage_mismatch = 0;      // pixels covered in one image only
  double albedo_psnr_db = 0.0;    // over the union, empty pixels as black; inf if equal
  double albedo_psnr_shared_db = 0.0;  // over the intersection only (colour fidelity); inf if equal
  int albedo_max_diff = 0;        // over the intersection, 8-bit levels
  int normal_max_diff = 0;        // over the intersection, 16-bit levels
  int depth_max_diff = 0;         // over the intersection, 16-bit levels
  int orm_max_diff = 0;
};

inline Comparison Compare(const ViewImages& a, const ViewImages& b) {
  Comparison c;
  int inter = 0, uni = 0;
  double sq = 0.0;
  long samples = 0;
  double shared_sq = 0.0;
  long shared_samples = 0;
  const size_t n = static_cast<size_t>(a.width) * a.height;
  for (size_t i = 0; i < n; ++i) {
    const bool ca = a.albedo_alpha[i * 4 + 3] >= 128;
    const bool cb = b.albedo_alpha[i * 4 + 3] >= 128;
    if (ca || cb) ++uni;
    if (ca != cb) ++c.coverage_mismatch;
    for (int k = 0; k < 3 && (ca || cb); ++k) {
      const double d = (ca ? a.albedo_alpha[i * 4 + k] : 0) - (cb ? b.albedo_alpha[i * 4 + k] : 0);
      sq += d * d;
      ++samples;
    }
    if (!(ca && cb)) continue;
    ++inter;
    for (int k = 0; k < 3; ++k) {
      const double ds = a.albedo_alpha[i * 4 + k] - b.albedo_alpha[i * 4 + k];
      shared_sq += ds * ds;
      ++shared_samples;
    }
    for (int k = 0; k < 3; ++k) {
      c.albedo_max_diff = std::max(c.albedo_max_diff, std::abs(a.albedo_alpha[i * 4 + k] - b.albedo_alpha[i * 4 + k]));
      c.normal_max_diff = std::max(c.normal_max_diff, std::abs(a.normal_depth[i * 4 + k] - b.normal_depth[i * 4 + k]));
      if (!a.orm.empty() && !b.orm.empty()) {
        c.orm_max_diff = std::max(c.orm_max_diff, std::abs(a.orm[i * 4 + k] - b.orm[i * 4 + k]));
      }
    }
    c.depth_max_diff = std::max(c.depth_max_diff, std::abs(a.normal_depth[i * 4 + 3] - b.normal_depth[i * 4 + 3]));
  }
  c.iou = uni == 0 ? 1.0 : static_cast<double>(inter) / uni;
  const double mse = samples == 0 ? 0.0 : sq / samples;
  c.albedo_psnr_db = mse == 0.0 ? std::numeric_limits<double>::infinity() : 10.0 * std::log10(255.0 * 255.0 / mse);
  const double shared_mse = shared_samples == 0 ? 0.0 : shared_sq / shared_samples;
  c.albedo_psnr_shared_db = shared_mse == 0.0 ? std::numeric_limits<double>::infinity()
                                              : 10.0 * std::log10(255.0 * 255.0 / shared_mse);
  return c;
}

// Pixels covered in both images whose normal (any component) or depth
// differs by more than the given 16-bit levels. A GPU's float rounding can
// flip a discrete choice (a march step's hit test, a texel's floor) at a
// pixel that sits on the tie, and that pixel then differs by a whole texel
// step; such pixels are counted rather than bounding the largest difference.
struct PixelsBeyond {
  int normal = 0;
  int depth = 0;
};

inline PixelsBeyond CountPixelsBeyond(const ViewImages& a, const ViewImages& b, int normal_levels,
                                      int depth_levels) {
  PixelsBeyond out;
  const size_t n = static_cast<size_t>(a.width) * a.height;
  for (size_t i = 0; i < n; ++i) {
    if (a.albedo_alpha[i * 4 + 3] < 128 || b.albedo_alpha[i * 4 + 3] < 128) continue;
    int normal = 0;
    for (int k = 0; k < 3; ++k) normal = std::max(normal, std::abs(a.normal_depth[i * 4 + k] - b.normal_depth[i * 4 + k]));
    if (normal > normal_levels) ++out.normal;
    if (std::abs(a.normal_depth[i * 4 + 3] - b.normal_depth[i * 4 + 3]) > depth_levels) ++out.depth;
  }
  return out;
}

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_RUNTIME_IMAGE_COMPARE_H_
