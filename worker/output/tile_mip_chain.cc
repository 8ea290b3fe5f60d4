#include "worker/output/tile_mip_chain.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "worker/output/atlas_dilation.h"
#include "worker/output/coverage_scale.h"

namespace impostor {
namespace {

absl::Status CheckTiles(std::span<const TileRect> tiles, int levels) {
  const int step = 1 << (levels - 1);
  for (const TileRect& t : tiles) {
    if (t.x % step != 0 || t.y % step != 0 || t.width % step != 0 || t.height % step != 0) {
      return absl::InvalidArgumentError(absl::StrCat("tile at (", t.x, ", ", t.y, ") of ", t.width, "x", t.height,
                                                     " px is not aligned to ", step, " px, needed for ", levels,
                                                     " mip levels"));
    }
  }
  return absl::OkStatus();
}

size_t At(int x, int y, int width) { return (static_cast<size_t>(y) * width + x) * 4; }

}  // namespace

std::vector<TileRect> TilesAtLevel(std::span<const TileRect> tiles, int level) {
  std::vector<TileRect> out;
  out.reserve(tiles.size());
  for (const TileRect& t : tiles) out.push_back({t.x >> level, t.y >> level, t.width >> level, t.height >> level});
  return out;
}

absl::StatusOr<std::vector<MipLevel<uint8_t>>> BuildCoverageMipChain(std::span<const uint8_t> rgba, int width,
                                                                   int height, std::span<const TileRect> tiles,
                                                                   int levels, MipCoverage coverage) {
  if (levels < 1) return absl::InvalidArgumentError(absl::StrCat("mip levels: ", levels, " (at least 1)"));
  if (width < 1 || height < 1 || rgba.size() != static_cast<size_t>(width) * height * 4) {
    return absl::InvalidArgumentError(
        absl::StrCat("mip chain: ", rgba.size(), " values for a ", width, "x", height, " RGBA image"));
  }
  if (auto s = CheckTiles(tiles, levels); !s.ok()) return s;
  // Level 0's covered texels per tile: what every level's tile should keep.
  std::vector<int64_t> covered0;
  for (const TileRect& t : tiles) {
    auto covered = CoveredTexels(rgba, width, height, t);
    if (!covered.ok()) return covered.status();
    covered0.push_back(*covered);
  }
  std::vector<MipLevel<uint8_t>> chain;
  chain.reserve(levels);  // `up` below may refer to chain[0]
  chain.push_back({width, height, std::vector<uint8_t>(rgba.begin(), rgba.end())});
  // The level above as the box filter made it, before its alpha was scaled:
  // level 0 itself (never scaled), then `box`.
  MipLevel<uint8_t> box;
  for (int level = 1; level < levels; ++level) {
    const MipLevel<uint8_t>& up = level == 1 ? chain[0] : box;
    MipLevel<uint8_t> next{std::max(1, up.width / 2), std::max(1, up.height / 2), {}};
    next.rgba.resize(static_cast<size_t>(next.width) * next.height * 4);
    for (int y = 0; y < next.height; ++y) {
      for (int x = 0; x < next.width; ++x) {
        for (int c = 0; c < 4; ++c) {
          const int sum = up.rgba[At(2 * x, 2 * y, up.width) + c] + up.rgba[At(2 * x + 1, 2 * y, up.width) + c] +
                          up.rgba[At(2 * x, 2 * y + 1, up.width) + c] +
                          up.rgba[At(2 * x + 1, 2 * y + 1, up.width) + c];
          next.rgba[At(x, y, next.width) + c] = static_cast<uint8_t>((sum + 2) / 4);
        }
      }
    }
    // Dilated at this level, inside each tile: empty texels take this
    // level's nearest covered colour of their own frame.
    const std::vector<TileRect> level_tiles = TilesAtLevel(tiles, level);
    if (auto s = DilateRgba8(next.rgba, next.width, next.height, level_tiles); !s.ok()) return s;
    MipLevel<uint8_t> shipped = next;
    if (coverage == MipCoverage::kPreserveAlphaTest) {
      for (size_t i = 0; i < level_tiles.size(); ++i) {
        const int64_t area0 = static_cast<int64_t>(tiles[i].width) * tiles[i].height;
        auto scaled =
            ScaleAlphaToCoverage(shipped.rgba, shipped.width, shipped.height, level_tiles[i], covered0[i], area0);
        if (!scaled.ok()) return scaled.status();
      }
    }
    box = std::move(next);
    chain.push_back(std::move(shipped));
  }
  return chain;
}

absl::StatusOr<std::vector<double>> CoverageByLevel(std::span<const MipLevel<uint8_t>> chain,
                                                    std::span<const TileRect> tiles) {
  std::vector<double> ratios;
  int64_t covered0 = 0;
  for (size_t level = 0; level < chain.size(); ++level) {
    const MipLevel<uint8_t>& l = chain[level];
    int64_t covered = 0;
    for (const TileRect& t : TilesAtLevel(tiles, static_cast<int>(level))) {
      auto n = CoveredTexels(l.rgba, l.width, l.height, t);
      if (!n.ok()) return n.status();
      covered += *n;
    }
    if (level == 0) covered0 = covered;
    // A level-L texel stands for 4^L texels of level 0.
    const double as_level0 = static_cast<double>(covered) * static_cast<double>(int64_t{1} << (2 * level));
    ratios.push_back(covered0 == 0 ? 1.0 : as_level0 / static_cast<double>(covered0));
  }
  return ratios;
}

absl::StatusOr<std::vector<MipLevel<uint16_t>>> BuildNormalDepthMipChain(
    std::span<const uint16_t> rgba, std::span<const MipLevel<uint8_t>> coverage, std::span<const TileRect> tiles) {
  if (coverage.empty()) return absl::InvalidArgumentError("mip chain: no coverage levels");
  const int width = coverage[0].width, height = coverage[0].height;
  const int levels = static_cast<int>(coverage.size());
  if (rgba.size() != static_cast<size_t>(width) * height * 4) {
    return absl::InvalidArgumentError(absl::StrCat("mip chain: ", rgba.size(), " normal_depth values for a ", width,
                                                   "x", height, " RGBA image"));
  }
  if (auto s = CheckTiles(tiles, levels); !s.ok()) return s;
  std::vector<MipLevel<uint16_t>> chain;
  chain.push_back({width, height, std::vector<uint16_t>(rgba.begin(), rgba.end())});
  for (int level = 1; level < levels; ++level) {
    const MipLevel<uint16_t>& up = chain.back();
    const MipLevel<uint8_t>& up_cov = coverage[level - 1];
    MipLevel<uint16_t> next{coverage[level].width, coverage[level].height, {}};
    next.rgba.resize(static_cast<size_t>(next.width) * next.height * 4);
    for (int y = 0; y < next.height; ++y) {
      for (int x = 0; x < next.width; ++x) {
        double n[3] = {0, 0, 0};
        double depth = 0;
        int covered = 0;
        for (int k = 0; k < 4; ++k) {
          const size_t i = At(2 * x + k % 2, 2 * y + k / 2, up.width);
          for (int c = 0; c < 3; ++c) n[c] += up.rgba[i + c] / 65535.0 * 2.0 - 1.0;
          if (up_cov.rgba[i + 3] > 0) {
            depth += up.rgba[i + 3];
            ++covered;
          }
        }
        const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        const size_t o = At(x, y, next.width);
        for (int c = 0; c < 3; ++c) {
          const double v = len > 1e-9 ? n[c] / len : n[c] / 4.0;
          next.rgba[o + c] = static_cast<uint16_t>(std::lround((v * 0.5 + 0.5) * 65535.0));
        }
        next.rgba[o + 3] = covered > 0 ? static_cast<uint16_t>(std::lround(depth / covered)) : uint16_t{65535};
      }
    }
    const std::vector<TileRect> level_tiles = TilesAtLevel(tiles, level);
    if (auto s = DilateRgba16(next.rgba, coverage[level].rgba, next.width, next.height, level_tiles); !s.ok()) {
      return s;
    }
    chain.push_back(std::move(next));
  }
  return chain;
}

absl::Status DilateDepth(MipLevel<uint16_t>& level, const MipLevel<uint8_t>& coverage,
                         std::span<const TileRect> level_tiles) {
  if (level.width != coverage.width || level.height != coverage.height ||
      level.rgba.size() != static_cast<size_t>(level.width) * level.height * 4) {
    return absl::InvalidArgumentError(absl::StrCat("depth dilation: a ", level.width, "x", level.height,
                                                   " level against ", coverage.width, "x", coverage.height,
                                                   " coverage"));
  }
  // DilateRgba16 fills RGB: carry depth in R and back.
  std::vector<uint16_t> depth(level.rgba.size(), 0);
  for (size_t i = 0; i < depth.size(); i += 4) depth[i] = level.rgba[i + 3];
  if (auto s = DilateRgba16(depth, coverage.rgba, level.width, level.height, level_tiles, kDilateWholeTile,
                            std::nullopt);
      !s.ok()) {
    return s;
  }
  for (size_t i = 0; i < depth.size(); i += 4) level.rgba[i + 3] = depth[i];
  return absl::OkStatus();
}

}  // namespace impostor
