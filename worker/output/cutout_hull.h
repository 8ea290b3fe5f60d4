// The cutout polygon of an impostor atlas: one convex polygon, in tile
// coordinates, that contains every opaque texel of every frame, so a game
// can draw the impostor as that polygon instead of the whole quad and skip
// the transparent overdraw (the Unity notes' "convex hull cutout mesh"; the
// engine documentation's cutout hull in the description).
//
// Method: the texels covered in any frame are OR-ed into one tile-sized
// mask; the convex hull (Andrew's monotone chain) of the covered texels'
// corners is then simplified to at most `max_vertices` by repeatedly
// removing the edge whose removal adds the least area: its two neighbouring
// edges are extended to meet in a new vertex (the polygon only grows, so it
// still contains every texel; a removal whose new vertex would leave the
// tile is not taken, so UVs never reach a neighbouring frame). When no
// removal fits, the tile square itself (4 vertices) is returned.
//
// Pure functions, thread-safe.
#ifndef IMPOSTOR_WORKER_OUTPUT_CUTOUT_HULL_H_
#define IMPOSTOR_WORKER_OUTPUT_CUTOUT_HULL_H_

#include <cstdint>
#include <span>
#include <vector>

#include <glm/vec2.hpp>

#include "absl/status/statusor.h"
#include "common/atlas/frame_camera.h"

namespace impostor {

inline constexpr int kDefaultCutoutVertices = 8;

struct CutoutPolygon {
  // Vertices in tile coordinates: u = x / tile width, v = y / tile height,
  // both 0..1, v = 0 at the top row of the tile (as the image). Ordered
  // counter-clockwise as the image is displayed (y down); 3..max_vertices.
  std::vector<glm::vec2> vertices;
  // Polygon area / tile area, 0..1: the share of the quad still drawn.
  float area_ratio = 1.0f;
};

// Convex polygon around every texel with alpha > 0 (RGBA8, `width` x
// `height`, rows top to bottom) inside `tiles` (all the same size).
// A mask with no covered texel gives the whole tile (area_ratio 1).
// INVALID_ARGUMENT for a buffer of the wrong size, tiles of different sizes
// or outside the image, or max_vertices < 4.
absl::StatusOr<CutoutPolygon> ComputeCutout(std::span<const uint8_t> rgba, int width, int height,
                                            std::span<const TileRect> tiles,
                                            int max_vertices = kDefaultCutoutVertices);

// The same from a tile-sized coverage mask (1 = covered), in pixel units of
// a `tile_width` x `tile_height` tile.
CutoutPolygon CutoutFromMask(std::span<const uint8_t> mask, int tile_width, int tile_height, int max_vertices);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_OUTPUT_CUTOUT_HULL_H_
