// Defaults, limits and normalisation of the quality-pass fields of a bake
// request (BakeParameters.quality_views, frames_auto, auto_target). Pure
// functions, thread-safe; called by NormalizeParameters and ComputeCacheKey.
#ifndef IMPOSTOR_COMMON_REQUEST_QUALITY_PARAMETERS_H_
#define IMPOSTOR_COMMON_REQUEST_QUALITY_PARAMETERS_H_

#include <cstdint>
#include <string>

#include "absl/status/status.h"
#include "impostor/v1/types.pb.h"

namespace impostor {

// Held-out views of the quality pass when quality_views is unset, and the
// most a request may ask for (each costs a mesh and an impostor render).
inline constexpr uint32_t kDefaultQualityViewCount = 16;
inline constexpr uint32_t kMaxQualityViewCount = 256;

// With out->product() and out->layout() resolved: for atlas products
// (PRODUCT_ATLAS, PRODUCT_LOD_CHAIN's impostor) fills quality_views in (16)
// and checks it (0..256, 0 = no quality pass); checks frames_auto (frames
// unset, ring-top's ring_views unset, auto_target with at least one
// threshold in range, quality_views > 0; every layout, with the ladder of
// common/request/auto_frames_ladder.h) and refuses auto_target without frames_auto.
// Other products must leave all three unset. INVALID_ARGUMENT naming the
// field and the rule, e.g. "parameters.quality_views: 300 is out of range
// 0..256".
absl::Status NormalizeQualityParameters(const v1::BakeParameters& in, v1::BakeParameters* out);

// The cache key's line for these fields: empty for the defaults (so atlas
// keys from before the quality pass keep their value), else e.g.
// "quality_views 32 frames_auto min_iou 0.95 min_psnr_db -".
std::string QualityCacheKeyLine(const v1::BakeParameters& normalized);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_REQUEST_QUALITY_PARAMETERS_H_
