// Layout of the card atlas: every card gets a pixel rectangle at one shared
// texel density (texels per scene unit, the same for every card, so a 1 m
// card and a 2 m card show the same detail), with a gutter of empty texels
// around it that dilation fills from the card's own colours, so bilinear
// filtering and mipmaps never pull in a neighbour. Cards are placed on
// shelves, tallest first; the density is the largest (found by bisection)
// at which they all fit.
//
// Pure functions; thread-safe.
#ifndef IMPOSTOR_WORKER_CARDS_CARD_PACKING_H_
#define IMPOSTOR_WORKER_CARDS_CARD_PACKING_H_

#include <span>
#include <vector>

#include "absl/status/statusor.h"
#include "common/atlas/frame_camera.h"
#include "worker/cards/card_rect.h"

namespace impostor {

struct CardPacking {
  float texels_per_unit = 0.0f;
  int gutter = 0;  // empty texels on each side of a card's rectangle
  // Per card: its rectangle, exactly ceil(2 * half_u * texels_per_unit) by
  // ceil(2 * half_v * texels_per_unit) texels (at least 1 x 1). Row 0 of a
  // rectangle is the card's +v edge, column 0 its -u edge.
  std::vector<TileRect> tiles;
};

// Gutter width used for an atlas of `resolution` texels: 2 texels up to
// 512, then resolution / 256 (survives that many mip levels' worth of
// filtering at larger sizes).
int CardGutter(int resolution);

// Packs `cards` into a `resolution` x `resolution` atlas. INVALID_ARGUMENT
// when they cannot fit even at one texel each (the message names the count
// and the resolution).
absl::StatusOr<CardPacking> PackCards(std::span<const CardRect> cards, int resolution);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_CARDS_CARD_PACKING_H_
