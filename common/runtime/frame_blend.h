// Which baked frames a runtime blends for a view direction, and how much of
// each. Shared by the CPU reference renderer, the client SDK
// (client/include/impostor/runtime.h) and mirrored line by line by the
// reference shader shaders/impostor_runtime.glsl.
//
// The view direction is in object space: the unit vector from the bounding
// sphere's centre toward the camera (as in common/atlas/atlas_layout.h). Its grid
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
//
// The other layouts (BlendFrames(const ViewLayout&, ...)) use their own grids
// (common/atlas/atlas_layout.h). Azimuth and elevation are computed as
//   az = atan2(d.x, d.z) wrapped into [0, 2 pi),  el = atan2(d.y, |d.xz|)
// (the same angles as DirectionToAzimuthElevation, but well conditioned near
// the poles; az = 0 on the Y axis itself).
//
// azimuth-elevation (N x N): column position u = az * N / (2 pi), row
// position v = (pi/2 - el) * N / pi - 0.5 (0 on row 0's elevation, growing
// downward). The cell is columns c0 = floor(u), c1 = (c0 + 1) % N (the
// azimuth wraps: column N-1 blends with column 0) and rows r0 = clamp(floor(v),
// 0, N-2), r1 = r0 + 1, fx = u - c0, fy = clamp(v - r0, 0, 1): above row 0's
// elevation or below row N-1's, fy clamps and only that row's two frames
// blend, across azimuth. kBilinear4 and kTriangle3 use the octahedral
// formulas above on this cell (triangle3 splits it along the c0-c3
// diagonal, from (c0, r0) to (c1, r1)).
// The poles: azimuth is undefined on the Y axis, so a blend across azimuth
// alone would jump there. Between row 0's elevation and +Y (the cap
// -0.5 <= v < 0) the cell's weights are scaled by 1 - t and the frame of
// column 0, row 0 gets t = clamp(-2 v, 0, 1) (0 on the row, 1 at the pole);
// likewise below row N-1 with column 0, row N-1 and t = clamp(2 (v - (N-1)),
// 0, 1). Every frame of a cap's row is the same 90/N degrees from its pole,
// so column 0 is an arbitrary but fixed choice (it is also NearestFrame's
// tie-break at the pole): the weights are continuous everywhere, including
// the pole, and at most 3 frames are used in the caps.
//
// ring-top and billboard (K ring frames at el = 0, frame K from above):
// the two ring frames bracketing the azimuth, k0 = floor(az * K / (2 pi)),
// k1 = (k0 + 1) % K, fx = az * K / (2 pi) - k0, and the top frame with
//   t = clamp(el / (pi/2), 0, 1)   (below the horizon: 0, ring only)
// giving (1 - t)(1 - fx) on k0, (1 - t) fx on k1 and t on the top frame.
// This is the barycentric blend of the spherical triangle (k0, k1, top)
// parametrised by (azimuth, elevation): full weight on a ring frame at its
// own direction and on the top frame straight above, continuous across the
// azimuth wrap and at the pole (t -> 1 whatever the azimuth), and the top
// frame outweighs the ring exactly when the view is above 45 degrees. Both
// blend modes give this same blend (the cell is already a triangle).
//
// For every layout `frame` is the frame's tile (FrameTile; for the
// octahedral layouts its grid vertex), `index` the frame index. Where all
// the weight is on one frame, that frame is NearestFrame's answer.
#ifndef IMPOSTOR_COMMON_RUNTIME_FRAME_BLEND_H_
#define IMPOSTOR_COMMON_RUNTIME_FRAME_BLEND_H_

#include <array>
#include <string_view>

#include <glm/vec3.hpp>

#include "absl/status/statusor.h"
#include "common/atlas/atlas_layout.h"

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
  FrameCoord frame;   // canonical frame: its tile, FrameTile(layout, index)
  int index = 0;      // frame index (FrameIndex(frames, frame) on the grid layouts)
  float weight = 0.0f;
};

struct FrameBlend {
  int count = 0;                       // 1..4 entries used (3 for ring-top, billboard)
  std::array<FrameWeight, 4> entries;  // weights > 0, summing to 1
};

// The frames to blend for `direction` (need not be normalised; a zero or
// non-finite direction is taken as straight up, +Y). `frames` >= 1.
// For ring-top use the ViewLayout form (this one takes ring_views = 0 for
// it, and a ring of no views blends frame 0 alone); billboard needs none.
FrameBlend BlendFrames(LayoutKind layout, int frames, glm::vec3 direction, BlendMode mode);

// Any layout. A layout with no frames (frames < 1 on the grid layouts,
// ring_views < 1 on ring-top) gives frame 0 with weight 1.
FrameBlend BlendFrames(const ViewLayout& layout, glm::vec3 direction, BlendMode mode);

// The layout's description from (kind, frames): ring_views = 8 for
// billboard, 0 otherwise.
ViewLayout ViewLayoutFor(LayoutKind kind, int frames);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_RUNTIME_FRAME_BLEND_H_
