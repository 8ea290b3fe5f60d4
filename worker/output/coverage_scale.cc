#include "worker/output/coverage_scale.h"

#include <algorithm>
#include <array>
#include <cstdlib>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

absl::Status CheckTile(size_t values, int width, int height, const TileRect& t) {
  if (width < 1 || height < 1 || values != static_cast<size_t>(width) * height * 4) {
    return absl::InvalidArgumentError(
        absl::StrCat("coverage: ", values, " values for a ", width, "x", height, " RGBA image"));
  }
  if (t.x < 0 || t.y < 0 || t.width < 0 || t.height < 0 || t.x + t.width > width || t.y + t.height > height) {
    return absl::InvalidArgumentError(absl::StrCat("coverage: tile at (", t.x, ", ", t.y, ") of ", t.width, "x",
                                                   t.height, " px lies outside the ", width, "x", height,
                                                   " image"));
  }
  return absl::OkStatus();
}

size_t Alpha(int x, int y, int width) { return (static_cast<size_t>(y) * width + x) * 4 + 3; }

}  // namespace

absl::StatusOr<int64_t> CoveredTexels(std::span<const uint8_t> rgba, int width, int height, const TileRect& tile) {
  if (auto s = CheckTile(rgba.size(), width, height, tile); !s.ok()) return s;
  int64_t covered = 0;
  for (int y = tile.y; y < tile.y + tile.height; ++y) {
    for (int x = tile.x; x < tile.x + tile.width; ++x) covered += rgba[Alpha(x, y, width)] >= kCoverageCutoff;
  }
  return covered;
}

absl::StatusOr<int64_t> ScaleAlphaToCoverage(std::span<uint8_t> rgba, int width, int height, const TileRect& tile,
                                             int64_t want_covered, int64_t want_area) {
  if (auto s = CheckTile(rgba.size(), width, height, tile); !s.ok()) return s;
  if (want_area < 1 || want_covered < 0 || want_covered > want_area) {
    return absl::InvalidArgumentError(
        absl::StrCat("coverage: ", want_covered, " covered texels of ", want_area, " wanted"));
  }
  // at_least[t]: texels with A >= t. Scaling A by 128 / t makes exactly
  // these pass the cutoff, so choosing t is choosing the scale.
  std::array<int64_t, 257> at_least{};
  for (int y = tile.y; y < tile.y + tile.height; ++y) {
    for (int x = tile.x; x < tile.x + tile.width; ++x) ++at_least[rgba[Alpha(x, y, width)]];
  }
  for (int t = 254; t >= 0; --t) at_least[t] += at_least[t + 1];
  if (want_covered == 0 || want_covered == want_area) return at_least[kCoverageCutoff];
  // |covered / area - want_covered / want_area|, scaled by both areas so it
  // stays an integer. Ties go to the threshold nearest the cutoff (the
  // smallest change; 128 itself leaves the tile as it is).
  const int64_t area = static_cast<int64_t>(tile.width) * tile.height;
  auto error = [&](int t) { return std::abs(at_least[t] * want_area - want_covered * area); };
  int best = kCoverageCutoff;
  for (int t = 1; t <= 255; ++t) {
    const int64_t e = error(t), b = error(best);
    if (e < b || (e == b && std::abs(t - kCoverageCutoff) < std::abs(best - kCoverageCutoff))) best = t;
  }
  if (best == kCoverageCutoff) return at_least[kCoverageCutoff];
  // a >= best gives a * 128 / best >= 128; a < best gives < 128 (integer
  // division rounds down), so exactly at_least[best] texels pass.
  for (int y = tile.y; y < tile.y + tile.height; ++y) {
    for (int x = tile.x; x < tile.x + tile.width; ++x) {
      uint8_t& a = rgba[Alpha(x, y, width)];
      if (a == 0) continue;
      a = static_cast<uint8_t>(std::clamp(a * kCoverageCutoff / best, 1, 255));
    }
  }
  return at_least[best];
}

}  // namespace impostor
