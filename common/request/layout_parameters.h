// Validation and defaults of the view-layout fields of a bake request
// (layout, frames, ring_views), one layout at a time. Part of
// NormalizeParameters (bake_request.h); pure, thread-safe.
#ifndef IMPOSTOR_COMMON_REQUEST_LAYOUT_PARAMETERS_H_
#define IMPOSTOR_COMMON_REQUEST_LAYOUT_PARAMETERS_H_

#include <cstdint>

#include "absl/status/status.h"
#include "common/atlas/atlas_layout.h"
#include "impostor/v1/types.pb.h"

namespace impostor {

inline constexpr uint32_t kDefaultAzimuthElevationFrames = 11;
inline constexpr uint32_t kDefaultRingViews = 24;

// With `out->layout()` already resolved from UNSPECIFIED: fills the
// layout's frame defaults in and checks them. INVALID_ARGUMENT naming the
// field, e.g. "parameters.frames: azimuth-elevation needs an odd row count
// so that a row sits at 0 degrees elevation; got 8 (use 7 or 9)".
//   azimuth-elevation: frames default 11, odd, 3..63.
//   ring-top: ring_views default 24 (3..64); frames is derived (the atlas
//     grid side, ceil(sqrt(ring_views + 1))) and must be left unset.
//   billboard: frames is derived (3); ring_views must be unset.
//   octahedral layouts: ring_views must be unset; octahedral needs frames
//     >= 3 (2 puts every frame on the map's folded corners: one view, four
//     times).
// Surfel captures take the octahedral layouts only.
absl::Status NormalizeLayoutFrames(v1::BakeParameters* out);

inline constexpr uint32_t kDefaultSupersampling = 2;
inline constexpr uint32_t kMaxSupersampling = 4;
// The largest image the baker renders (resolution x supersampling), the
// maxImageDimension2D every Vulkan 1.3 desktop driver and lavapipe offer.
inline constexpr uint32_t kMaxRenderPixels = 16384;

// With resolution filled in: supersampling default 2 for the atlas and
// LOD-chain products (range 1..4, and resolution x supersampling at most
// kMaxRenderPixels); refused for the others, whose captures do not filter.
// texture_array is refused for the same products.
absl::Status NormalizeSupersampling(v1::BakeParameters* out);

// The shared mapping's description of a normalised request's layout.
ViewLayout ViewLayoutOf(const v1::BakeParameters& normalized);
LayoutKind LayoutKindOf(v1::Layout layout);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_REQUEST_LAYOUT_PARAMETERS_H_
