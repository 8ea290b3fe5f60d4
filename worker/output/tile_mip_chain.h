// The mip chain of a baked atlas, made for impostors: each level is the 2x2
// box filter of the one above and is then dilated again, tile by tile, so a
// level's empty texels take the colour of that level's own silhouette and
// never another frame's. With tiles that start on multiples of 2^L (as
// TileSize / BlockAlignedTileSize lay them out), every 2x2 footprint of
// levels 1..L lies inside one tile, so no level mixes two frames.
//
// Coverage (albedo alpha, ORM alpha) is box filtered like colour and then,
// by default, scaled per tile so that as many texels pass the runtime's
// alpha test as at level 0 (coverage_scale.h): thin features such as leaf
// tips do not fade out of the distant levels. Depth
// (normal_depth alpha) is the mean of the covered parents only, so the
// silhouette's depth is not pulled toward "far"; normals are the mean of the
// parents, renormalised.
//
// Pure functions, thread-safe on distinct images.
#ifndef IMPOSTOR_WORKER_OUTPUT_TILE_MIP_CHAIN_H_
#define IMPOSTOR_WORKER_OUTPUT_TILE_MIP_CHAIN_H_

#include <cstdint>
#include <span>
#include <vector>

#include "absl/status/statusor.h"
#include "common/atlas/frame_camera.h"

namespace impostor {

template <typename T>
struct MipLevel {
  int width = 0;
  int height = 0;
  std::vector<T> rgba;  // width * height * 4, rows top to bottom
};

// What a level's coverage is.
enum class MipCoverage {
  // The box filter's alpha scaled per tile so that the tile's alpha-tested
  // area matches level 0's (ScaleAlphaToCoverage). What bakes ship.
  kPreserveAlphaTest,
  // The box filter's alpha as it is (the mean coverage; what a generic mip
  // generator gives). For comparisons.
  kBoxFilter,
};

// Levels 0..levels-1 of an RGBA8 map whose alpha is coverage (albedo, ORM,
// emissive); level 0 is `rgba` as given (already dilated). `tiles` are
// level 0's tiles. Each level is built from the box-filtered level above
// before its alpha was scaled, so scaling never compounds; colour does not
// depend on `coverage`, and maps with the same level-0 alpha get the same
// alpha at every level. INVALID_ARGUMENT if the buffer size is wrong,
// levels < 1, a tile lies outside the image or does not start and end on
// multiples of 2^(levels-1) (its texels would mix with a neighbour's).
absl::StatusOr<std::vector<MipLevel<uint8_t>>> BuildCoverageMipChain(
    std::span<const uint8_t> rgba, int width, int height, std::span<const TileRect> tiles, int levels,
    MipCoverage coverage = MipCoverage::kPreserveAlphaTest);

// For each level of `chain` (an RGBA8 chain from BuildCoverageMipChain over
// `tiles`, level 0's), the fraction of the tiles' texels with A >=
// kCoverageCutoff divided by level 0's fraction: 1.0 = the alpha-tested area
// kept, 0.5 = half of it lost. 1.0 at every level when level 0 covers
// nothing. INVALID_ARGUMENT if a tile lies outside its level.
absl::StatusOr<std::vector<double>> CoverageByLevel(std::span<const MipLevel<uint8_t>> chain,
                                                    std::span<const TileRect> tiles);

// The same for the RGBA16 normal_depth map, whose coverage comes from the
// albedo chain built by BuildCoverageMipChain (same sizes and level count).
// Errors as above, plus a size mismatch with `coverage`.
absl::StatusOr<std::vector<MipLevel<uint16_t>>> BuildNormalDepthMipChain(
    std::span<const uint16_t> rgba, std::span<const MipLevel<uint8_t>> coverage, std::span<const TileRect> tiles);

// Block-compressed normal_depth: fills the depth (A) of empty texels with
// the nearest covered texel's depth of the same tile, as colour is dilated,
// so a 4x4 block at the silhouette does not have to code a jump to "far"
// (1.0) that no reader uses (coverage lives in the albedo map; readers weigh
// depth by it). INVALID_ARGUMENT on size mismatches.
absl::Status DilateDepth(MipLevel<uint16_t>& level, const MipLevel<uint8_t>& coverage,
                         std::span<const TileRect> level_tiles);

// The tiles of level `level`: each rectangle divided by 2^level.
std::vector<TileRect> TilesAtLevel(std::span<const TileRect> tiles, int level);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_OUTPUT_TILE_MIP_CHAIN_H_
