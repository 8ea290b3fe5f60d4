// Supersampling of the baked maps: the atlas is rendered at `factor` times
// its resolution (every tile scaled by the same factor, so each
// factor x factor block of texels lies inside one tile) and filtered down
// here with a box filter that respects straight alpha:
//   coverage  A = the fraction of the block's samples the mesh covers,
//               0..255 (255 = fully covered, 0 = empty);
//   albedo    the mean of the covered samples only, averaged in linear
//             light (sRGB decoded, then re-encoded), so colour at a
//             silhouette edge keeps the surface's colour instead of
//             darkening toward the empty texels' black;
//   normal    the mean of the covered samples' normals, renormalised;
//   depth     the mean of the covered samples' depths;
//   ORM       the mean of the covered samples;
//   emissive  (when present) as albedo.
// Texels no sample covers keep the empty encodings (albedo 0,0,0,0; normal
// 0.5,0.5,0.5 with depth 1; ORM 0,0,0,0).
//
// Pure function; thread-safe.
#ifndef IMPOSTOR_WORKER_OUTPUT_SUPERSAMPLE_H_
#define IMPOSTOR_WORKER_OUTPUT_SUPERSAMPLE_H_

#include <cstdint>
#include <vector>

#include "absl/status/status.h"

namespace impostor {

struct AtlasMaps {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> albedo_alpha;   // RGBA8, albedo sRGB-encoded
  std::vector<uint16_t> normal_depth;  // RGBA16
  std::vector<uint8_t> orm;            // RGBA8
  std::vector<uint8_t> emissive;       // RGBA8 sRGB like albedo, or empty
};

// Replaces `maps` (width and height multiples of `factor`) by its
// downsampled version. INVALID_ARGUMENT for factor < 1, sizes that are not
// multiples of it, or buffers that do not match the size.
absl::Status DownsampleMaps(int factor, AtlasMaps* maps);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_OUTPUT_SUPERSAMPLE_H_
