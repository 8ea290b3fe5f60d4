// Edge padding ("dilation") of baked atlas maps: the colour of empty texels
// is filled in from the nearest covered texels of the same tile, so that
// bilinear filtering and mipmaps at a silhouette blend with the object's own
// colours instead of black/background. Coverage (alpha, or the depth of the
// normal_depth map) is left as it is, so the fill never becomes visible.
//
// Fill rule: each empty texel takes the RGB of the nearest covered texel
// (Euclidean distance) of its tile, found with a two-pass nearest-seed
// propagation (Danielsson, "Euclidean distance mapping", CGIP 14, 1980,
// 8SSEDT variant): O(tile area), exact except for rare ties/near-ties.
// Only texels of the tile being filled are read or written: nothing ever
// crosses a tile border (neighbouring tiles are other views of the object).
// Tiles without covered texels stay as they are.
//
// Pure functions, thread-safe on distinct images.
#ifndef IMPOSTOR_WORKER_OUTPUT_ATLAS_DILATION_H_
#define IMPOSTOR_WORKER_OUTPUT_ATLAS_DILATION_H_

#include <cstdint>
#include <optional>
#include <span>

#include "absl/status/status.h"
#include "common/atlas/frame_camera.h"

namespace impostor {

// Grow until the whole tile is filled.
inline constexpr int kDilateWholeTile = -1;

// Dilates an RGBA8 map (albedo_alpha, orm) of `width` x `height` texels
// (rows top to bottom, 4 channels) in place: texels with alpha == 0 are
// empty. Only empty texels within `max_distance` texels (Euclidean) of a
// covered texel are filled; kDilateWholeTile fills the whole tile. Alpha is
// never changed.
// INVALID_ARGUMENT if the buffer size is not width * height * 4, a tile
// lies outside the image or max_distance < -1.
absl::Status DilateRgba8(std::span<uint8_t> rgba, int width, int height,
                         std::span<const TileRect> tiles, int max_distance = kDilateWholeTile);

// The same for RGBA16 maps with an explicit coverage source: `coverage_rgba8`
// is an RGBA8 map of the same size (the albedo_alpha map) whose alpha says
// which texels are covered. RGB of empty texels is dilated; their A is set
// to `empty_alpha` when given (normal_depth: 65535 = depth 1.0, "far"),
// else left unchanged. Errors as DilateRgba8, plus a coverage size mismatch.
absl::Status DilateRgba16(std::span<uint16_t> rgba, std::span<const uint8_t> coverage_rgba8,
                          int width, int height, std::span<const TileRect> tiles,
                          int max_distance = kDilateWholeTile,
                          std::optional<uint16_t> empty_alpha = uint16_t{65535});

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_OUTPUT_ATLAS_DILATION_H_
