// Defaults, limits and normalisation of the PRODUCT_CARDS bake parameters
// (BakeParameters.max_planes, tolerance, resolution). Pure functions,
// thread-safe; called by NormalizeParameters and ComputeCacheKey.
#ifndef IMPOSTOR_COMMON_REQUEST_CARD_PARAMETERS_H_
#define IMPOSTOR_COMMON_REQUEST_CARD_PARAMETERS_H_

#include <cstdint>
#include <string>

#include "absl/status/status.h"
#include "impostor/v1/types.pb.h"

namespace impostor {

// The most cards (planes): the seed's "typically 4-8" and a ceiling past
// which the cards stop being cheaper than the mesh they replace.
inline constexpr uint32_t kDefaultMaxPlanes = 8;
inline constexpr uint32_t kMinMaxPlanes = 1;
inline constexpr uint32_t kMaxMaxPlanes = 64;
// Tolerance as a fraction of the bounding-sphere radius.
inline constexpr float kDefaultCardTolerance = 0.05f;
inline constexpr float kMinCardTolerance = 0.0001f;
inline constexpr float kMaxCardTolerance = 1.0f;
// Card atlas side when unset. Smaller than an octahedral atlas's 2048: the
// cards share one atlas at one texel density, with no per-view duplication.
inline constexpr uint32_t kDefaultCardResolution = 1024;

// For product PRODUCT_CARDS fills max_planes (8), tolerance (0.05) and
// resolution (1024) into `out` and checks their ranges (max_planes 1..64,
// tolerance 0.0001..1 and finite, resolution as for atlases, 64..8192).
// Cards have no views: an explicit frames is refused, frames is set to 2
// (the smallest valid value, so that the atlas checks that follow accept
// every resolution in range) and layout is ignored (set to octahedral, since
// SDK clients send their default layout with every request), so neither
// changes the cache key. For
// any other product max_planes and tolerance must be unset. INVALID_ARGUMENT
// naming the field and the limit ("parameters.max_planes: 65 is out of
// range 1..64").
absl::Status NormalizeCardParameters(const v1::BakeParameters& in, v1::BakeParameters* out);

// The cache-key line of the card fields of normalised parameters, e.g.
// "max_planes 8 tolerance 0x3d4ccccd" (the float's bits, so distinct values
// never share a key).
std::string CardCacheKeyLine(const v1::BakeParameters& normalized);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_REQUEST_CARD_PARAMETERS_H_
