#include "worker/cards/card_packing.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

int TexelsFor(float half_extent, double density) {
  return std::max(1, static_cast<int>(std::ceil(2.0 * half_extent * density - 1e-6)));
}

// Shelf placement at `density`; false when the atlas overflows.
bool Place(std::span<const CardRect> cards, double density, int resolution, int gutter,
           std::vector<TileRect>* tiles) {
  std::vector<size_t> order(cards.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::vector<TileRect> out(cards.size());
  for (size_t i = 0; i < cards.size(); ++i) {
    out[i].width = TexelsFor(cards[i].half_u, density);
    out[i].height = TexelsFor(cards[i].half_v, density);
  }
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return out[a].height > out[b].height; });
  int x = 0, y = 0, shelf = 0;
  for (size_t i : order) {
    const int w = out[i].width + 2 * gutter, h = out[i].height + 2 * gutter;
    if (w > resolution) return false;
    if (x + w > resolution) {
      y += shelf;
      x = 0;
      shelf = 0;
    }
    if (y + h > resolution) return false;
    out[i].x = x + gutter;
    out[i].y = y + gutter;
    x += w;
    shelf = std::max(shelf, h);
  }
  *tiles = std::move(out);
  return true;
}

}  // namespace

int CardGutter(int resolution) { return std::max(2, resolution / 256); }

absl::StatusOr<CardPacking> PackCards(std::span<const CardRect> cards, int resolution) {
  CardPacking packing;
  packing.gutter = CardGutter(resolution);
  if (cards.empty()) return packing;
  float longest = 0.0f;
  for (const CardRect& c : cards) longest = std::max(longest, 2.0f * c.half_u);
  if (!(longest > 0.0f)) longest = 1.0f;
  double lo = 0.0, hi = (resolution - 2.0 * packing.gutter) / longest;
  std::vector<TileRect> tiles;
  if (!Place(cards, 1e-30, resolution, packing.gutter, &tiles)) {
    return absl::InvalidArgumentError(absl::StrCat("parameters.resolution: ", resolution, " px cannot hold ",
                                                   cards.size(), " cards with ", packing.gutter,
                                                   "-texel gutters; use a larger resolution or fewer planes"));
  }
  if (Place(cards, hi, resolution, packing.gutter, &tiles)) {
    lo = hi;
  } else {
    for (int i = 0; i < 48; ++i) {
      const double mid = 0.5 * (lo + hi);
      if (Place(cards, mid, resolution, packing.gutter, &tiles)) {
        lo = mid;
      } else {
        hi = mid;
      }
    }
  }
  Place(cards, lo, resolution, packing.gutter, &packing.tiles);
  packing.texels_per_unit = static_cast<float>(lo);
  return packing;
}

}  // namespace impostor
