// Defaults, limits and normalisation of the PRODUCT_LOD_CHAIN bake
// parameters (BakeParameters.lod_ratios, lod_pixel_error). Pure functions,
// thread-safe; called by NormalizeParameters and ComputeCacheKey.
#ifndef IMPOSTOR_COMMON_REQUEST_LOD_PARAMETERS_H_
#define IMPOSTOR_COMMON_REQUEST_LOD_PARAMETERS_H_

#include <array>
#include <string>

#include "absl/status/status.h"
#include "impostor/v1/types.pb.h"

namespace impostor {

// Simplified levels when lod_ratios is empty: about half and a tenth of the
// triangles, as the LOD seed asks.
inline constexpr std::array<float, 2> kDefaultLodRatios = {0.5f, 0.1f};
inline constexpr int kMaxLodRatios = 8;
// Screen-space error budget at each switch, pixels.
inline constexpr float kDefaultLodPixelError = 1.0f;
inline constexpr float kMinLodPixelError = 0.1f;
inline constexpr float kMaxLodPixelError = 16.0f;

// For product PRODUCT_LOD_CHAIN fills lod_ratios ([0.5, 0.1] when empty) and
// lod_pixel_error (1 when unset) into `out` and checks them: each ratio in
// (0, 1) and finite, strictly decreasing, at most kMaxLodRatios; pixel error
// in 0.1..16. For any other product the LOD fields must be unset. Returns
// INVALID_ARGUMENT naming the field (e.g. "parameters.lod_ratios[1]") and the
// rule it breaks.
absl::Status NormalizeLodParameters(const v1::BakeParameters& in, v1::BakeParameters* out);

// The cache-key line of the LOD fields of normalised parameters, e.g.
// "lod_ratios 0.5 0.1 lod_pixel_error 1" (floats printed exactly, so
// distinct values never share a key).
std::string LodCacheKeyLine(const v1::BakeParameters& normalized);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_REQUEST_LOD_PARAMETERS_H_
