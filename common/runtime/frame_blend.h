// Which baked frames a runtime blends for a view direction, and how much of
// each. Shared by the CPU reference renderer, the client SDK
// (client/include/impostor/runtime.h) and mirrored line by line by the
// reference shader shaders/impostor_runtime.glsl.
//
// The view direction is in object space: the unit vector from the bounding
// sphere's centre toward the camera (as in common/atlas_layout.h). Its grid
// position g = DirectionToGrid(layout, frames, direction) lies in the grid
// quad with corners
//   c0 = (x0, y0), c1 = (x0+1, y0), c2 = (x0, y0+1), c3 = (x0+1, y0+1),
//   x0 = min(floor(g.x), frames-2), fx = g.x - x0 (likewise y),
// so a direction on the last grid line belongs to the last quad (fx = 1).
//
// kTriangle3 (Ryan Brucks, "Octahedral Impostors", Epic 2018): the quad is
// split along its c0-c3 diagonal (the article's "current" and "lower right"
// frames). The weights are the article's A = 1 - max(fx, fy) on c0,
// B = |fx - fy| on c1 when fx > fy (the "right" frame) or on c2 otherwise
// (the "lower" frame; ties pick c2, where B is 0 anyway), C = min(fx, fy) on c3.
// kBilinear4 (the 2x2 cell blend of the Cinevva article): c0..c3 with
// (1-fx)(1-fy), fx(1-fy), (1-fx)fy, fx*fy.
//
// Both are barycentric/bilinear interpolations on the grid, so weights sum to
// 1, are continuous in the direction (across quads and across the diagonal)
// and a frame's own direction gives it weight 1. Every frame is then mapped to
// CanonicalFrame (the octahedron's folded border: duplicates show the same
// view) and the weights of equal frames are merged, so the result lists each
// frame once. Frames whose weight is exactly 0 are dropped; the rest are
// ordered by the corner order above (first appearance). frames == 1 gives
// frame 0 with weight 1.
#ifndef IMPOSTOR_COMMON_RUNTIME_FRAME_BLEND_H_
#define IMPOSTOR_COMMON_RUNTIME_FRAME_BLEND_H_

#include <array>
#include <string_view>

#include <glm/vec3.hpp>

#include "absl/status/statusor.h"
#include "common/atlas_layout.h"

namespace impostor {

enum class BlendMode {
  kTriangle3,  // 3 frames, barycentric in a half grid quad
  kBilinear4,  // 4 frames, bilinear in the grid quad
};

// "triangle3" / "bilinear4".
std::string_view BlendModeName(BlendMode mode);
// INVALID_ARGUMENT naming the accepted values if `name` is not a blend mode.
absl::StatusOr<BlendMode> ParseBlendMode(std::string_view name);

struct FrameWeight {
  FrameCoord frame;   // canonical frame
  int index = 0;      // FrameIndex(frames, frame)
  float weight = 0.0f;
};

struct FrameBlend {
  int count = 0;                       // 1..4 entries used
  std::array<FrameWeight, 4> entries;  // weights > 0, summing to 1
};

// The frames to blend for `direction` (need not be normalised; a zero or
// non-finite direction is taken as straight up, +Y). `frames` >= 1.
FrameBlend BlendFrames(LayoutKind layout, int frames, glm::vec3 direction, BlendMode mode);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_RUNTIME_FRAME_BLEND_H_
