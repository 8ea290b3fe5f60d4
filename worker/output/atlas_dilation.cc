#include "worker/output/atlas_dilation.h"

#include <limits>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "common/util/parallel_for.h"

namespace impostor {
namespace {

absl::Status CheckArgs(size_t texels_given, size_t coverage_given, int width, int height,
                       std::span<const TileRect> tiles, int max_distance) {
  if (width < 0 || height < 0 || max_distance < kDilateWholeTile) {
    return absl::InvalidArgumentError(absl::StrCat("bad dilation arguments: ", width, "x", height,
                                                   ", max_distance ", max_distance));
  }
  const size_t expected = static_cast<size_t>(width) * height * 4;
  if (texels_given != expected || coverage_given != expected) {
    return absl::InvalidArgumentError(absl::StrCat("image buffers hold ", texels_given, " and ",
                                                   coverage_given, " values; a ", width, "x",
                                                   height, " RGBA image needs ", expected));
  }
  for (size_t i = 0; i < tiles.size(); ++i) {
    const TileRect& t = tiles[i];
    if (t.x < 0 || t.y < 0 || t.width < 0 || t.height < 0 || t.x > width - t.width ||
        t.y > height - t.height) {
      return absl::InvalidArgumentError(absl::StrCat("tile ", i, " (", t.x, ",", t.y, " ", t.width,
                                                     "x", t.height, ") lies outside the ", width,
                                                     "x", height, " image"));
    }
  }
  return absl::OkStatus();
}

// Fills one tile. `coverage` points at an RGBA8 image whose alpha marks
// covered texels (for RGBA8 maps it is the map itself).
template <typename T>
void DilateTile(T* rgba, const uint8_t* coverage, int width, const TileRect& tile, int max_distance,
                std::optional<T> empty_alpha) {
  const int w = tile.width, h = tile.height;
  if (w == 0 || h == 0) return;
  const auto texel = [&](int lx, int ly) {
    return (static_cast<size_t>(tile.y + ly) * width + (tile.x + lx)) * 4;
  };
  // Nearest covered texel found so far for each texel of the tile (local
  // coordinates), in a grid with a one-texel border that never holds a
  // seed, so the passes need no bounds checks and never look outside the
  // tile. kNone is far enough away to lose every comparison, and small
  // enough that squared distances to it fit in int64.
  struct Seed {
    int32_t x, y;
  };
  constexpr int32_t kNone = std::numeric_limits<int32_t>::min() / 4;
  const size_t pitch = static_cast<size_t>(w) + 2;
  std::vector<Seed> seeds(pitch * (static_cast<size_t>(h) + 2), Seed{kNone, kNone});
  const auto row = [&](int y) { return seeds.data() + (static_cast<size_t>(y) + 1) * pitch + 1; };
  bool any_covered = false;
  for (int y = 0; y < h; ++y) {
    Seed* r = row(y);
    for (int x = 0; x < w; ++x) {
      const size_t t = texel(x, y);
      if (coverage[t + 3] != 0) {
        r[x] = Seed{x, y};
        any_covered = true;
      } else if (empty_alpha) {
        rgba[t + 3] = *empty_alpha;
      }
    }
  }
  if (!any_covered) return;  // nothing to grow from

  const auto dist2 = [](const Seed& s, int x, int y) {
    const int64_t dx = int64_t{s.x} - x, dy = int64_t{s.y} - y;
    return dx * dx + dy * dy;
  };
  // Keeps whichever of `best` and `candidate` is nearer to (x, y).
  const auto relax = [&](Seed& best, int64_t& best_d2, const Seed& candidate, int x, int y) {
    const int64_t d = dist2(candidate, x, y);
    if (d < best_d2) {
      best_d2 = d;
      best = candidate;
    }
  };
  for (int y = 0; y < h; ++y) {  // forward pass: from the left and the row above
    Seed* r = row(y);
    const Seed* above = row(y - 1);
    for (int x = 0; x < w; ++x) {
      Seed s = r[x];
      int64_t d = dist2(s, x, y);
      relax(s, d, r[x - 1], x, y);
      relax(s, d, above[x - 1], x, y);
      relax(s, d, above[x], x, y);
      relax(s, d, above[x + 1], x, y);
      r[x] = s;
    }
    for (int x = w - 1; x >= 0; --x) {
      Seed s = r[x];
      int64_t d = dist2(s, x, y);
      relax(s, d, r[x + 1], x, y);
      r[x] = s;
    }
  }
  for (int y = h - 1; y >= 0; --y) {  // backward pass: from the right and the row below
    Seed* r = row(y);
    const Seed* below = row(y + 1);
    for (int x = w - 1; x >= 0; --x) {
      Seed s = r[x];
      int64_t d = dist2(s, x, y);
      relax(s, d, r[x + 1], x, y);
      relax(s, d, below[x + 1], x, y);
      relax(s, d, below[x], x, y);
      relax(s, d, below[x - 1], x, y);
      r[x] = s;
    }
    for (int x = 0; x < w; ++x) {
      Seed s = r[x];
      int64_t d = dist2(s, x, y);
      relax(s, d, r[x - 1], x, y);
      r[x] = s;
    }
  }

  const int64_t max_d2 =
      max_distance < 0 ? std::numeric_limits<int64_t>::max() : int64_t{max_distance} * max_distance;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const Seed& seed = row(y)[x];
      const int64_t d = dist2(seed, x, y);
      if (d == 0 || d > max_d2) continue;  // covered, or too far
      const int sx = seed.x, sy = seed.y;
      const size_t to = texel(x, y), from = texel(sx, sy);
      for (int c = 0; c < 3; ++c) rgba[to + c] = rgba[from + c];
    }
  }
}

// Whether no two tiles share a texel: then they can be filled side by side.
// (An atlas's tiles never overlap; a caller's list might.)
bool Disjoint(std::span<const TileRect> tiles) {
  for (size_t i = 0; i < tiles.size(); ++i) {
    const TileRect& a = tiles[i];
    for (size_t j = i + 1; j < tiles.size(); ++j) {
      const TileRect& b = tiles[j];
      if (a.x < b.x + b.width && b.x < a.x + a.width && a.y < b.y + b.height && b.y < a.y + a.height) return false;
    }
  }
  return true;
}

// Fills every tile: side by side on the machine's cores when they are
// disjoint (one tile's fill reads and writes only its own texels, so the
// result is the same), one after another otherwise. On a GPU host the
// bake's three maps were dilated on three threads while the other cores
// waited.
template <typename T>
void DilateTiles(T* rgba, const uint8_t* coverage, int width, std::span<const TileRect> tiles, int max_distance,
                 std::optional<T> empty_alpha) {
  auto fill = [&](size_t i) { DilateTile<T>(rgba, coverage, width, tiles[i], max_distance, empty_alpha); };
  if (Disjoint(tiles)) {
    ParallelFor(tiles.size(), fill);
  } else {
    for (size_t i = 0; i < tiles.size(); ++i) fill(i);
  }
}

}  // namespace

absl::Status DilateRgba8(std::span<uint8_t> rgba, int width, int height,
                         std::span<const TileRect> tiles, int max_distance) {
  if (absl::Status s = CheckArgs(rgba.size(), rgba.size(), width, height, tiles, max_distance);
      !s.ok()) {
    return s;
  }
  DilateTiles<uint8_t>(rgba.data(), rgba.data(), width, tiles, max_distance, std::nullopt);
  return absl::OkStatus();
}

absl::Status DilateRgba16(std::span<uint16_t> rgba, std::span<const uint8_t> coverage_rgba8,
                          int width, int height, std::span<const TileRect> tiles, int max_distance,
                          std::optional<uint16_t> empty_alpha) {
  if (absl::Status s =
          CheckArgs(rgba.size(), coverage_rgba8.size(), width, height, tiles, max_distance);
      !s.ok()) {
    return s;
  }
  DilateTiles<uint16_t>(rgba.data(), coverage_rgba8.data(), width, tiles, max_distance, empty_alpha);
  return absl::OkStatus();
}

}  // namespace impostor
