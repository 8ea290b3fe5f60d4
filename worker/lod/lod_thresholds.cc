#include "worker/lod/lod_thresholds.h"

#include <algorithm>

namespace impostor {

std::vector<float> LodThresholds(std::span<const float> mesh_errors, float radius, float pixel_error,
                                 float impostor_diameter_px) {
  const size_t n = mesh_errors.size();
  std::vector<float> t(n + 1, 0.0f);
  if (n == 0) return t;
  const float min_error = 1e-6f * radius;
  for (size_t i = 0; i + 1 < n; ++i) t[i] = pixel_error / std::max(mesh_errors[i + 1], min_error);
  t[n - 1] = impostor_diameter_px / (2.0f * radius);
  for (size_t i = n - 1; i-- > 0;) t[i] = std::max(t[i], t[i + 1]);
  return t;
}

}  // namespace impostor
