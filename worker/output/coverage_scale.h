// Alpha-tested coverage that survives mipmapping: the alpha of a mip level's
// tile is scaled so that the share of its texels an alpha test keeps matches
// level 0's share for that tile (Ignacio Castaño, "Computing Alpha Mipmaps",
// 2010, as NVIDIA Texture Tools' scaleAlphaToCoverage does it). A box filter
// keeps the mean alpha but not the tested area: a leaf tip one texel wide
// becomes alpha 64 two levels down and the alpha test drops it, so foliage
// thins out with distance.
//
// Castaño searches the scale factor by bisection. With 8-bit alpha the
// tested area only changes where the scale moves some value across the
// cutoff, so here every such threshold is tried from the tile's histogram:
// the result is the best match 8-bit alpha allows, in exact integer
// arithmetic (deterministic, the same bytes on every machine).
//
// Pure functions, thread-safe on distinct images.
#ifndef IMPOSTOR_WORKER_OUTPUT_COVERAGE_SCALE_H_
#define IMPOSTOR_WORKER_OUTPUT_COVERAGE_SCALE_H_

#include <cstdint>
#include <span>

#include "absl/status/statusor.h"
#include "common/atlas/frame_camera.h"

namespace impostor {

// The alpha from which a texel counts as covered. The reference runtime
// alpha-tests at 0.5 (shaders/impostor_runtime.glsl: covered = alpha >= 0.5)
// as engines do for a glTF MASK at the default cutoff, and 128 is the first
// 8-bit value that samples as >= 0.5 (128/255 = 0.502; 127/255 = 0.498).
inline constexpr int kCoverageCutoff = 128;

// Texels of `tile` in the RGBA8 image `rgba` (width x height, rows top to
// bottom) with A >= kCoverageCutoff. INVALID_ARGUMENT if the buffer does not
// match the size or the tile lies outside the image.
absl::StatusOr<int64_t> CoveredTexels(std::span<const uint8_t> rgba, int width, int height, const TileRect& tile);

// Scales A of the texels inside `tile` so that the fraction of them with
// A >= kCoverageCutoff comes as close as 8-bit alpha allows to
// want_covered / want_area (level 0's covered texels and area for the same
// tile). A texel that was 0 stays 0 and one that was not never becomes 0
// (what dilation and the normal_depth chain call empty is unchanged);
// scaled values clamp at 255. The tile is left as it is when want_covered
// is 0 or want_area (nothing or everything covered at level 0) or when its
// alpha already matches best. Returns the covered texels after scaling.
// INVALID_ARGUMENT as CoveredTexels, or for want_area < 1 or want_covered
// outside 0..want_area.
absl::StatusOr<int64_t> ScaleAlphaToCoverage(std::span<uint8_t> rgba, int width, int height, const TileRect& tile,
                                             int64_t want_covered, int64_t want_area);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_OUTPUT_COVERAGE_SCALE_H_
