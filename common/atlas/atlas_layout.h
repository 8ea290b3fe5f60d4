// Mapping between view directions and atlas frames for the octahedral and
// hemi-octahedral impostor layouts. One implementation, used by the worker
// (to place cameras), the manifest writer and the client SDK (to pick frames
// at run time), so that the baker and every consumer agree on every frame,
// including directions that fall on cell boundaries.
//
// Frames sit on the vertices of a virtual N x N grid laid over the
// octahedral square, as in Ryan Brucks' "Octahedral Impostors" (Epic Games,
// 2018): frame (col, row) is the grid vertex at
//   uv = (col / (N-1), row / (N-1)),   oct = uv * 2 - 1,
// and its tile in the atlas is column `col`, row `row`, row 0 at the top of
// the image. Placing frames on vertices (not cell centres) puts frames on the
// horizon of the hemi-octahedron and lets a runtime always blend the four
// vertices of the grid quad it is in, with no wrap-around at the border.
//
// Conventions (glTF): Y is up. `direction` is the unit vector from the
// bounding-sphere centre toward the camera.
//   octahedral:      +Y at the centre of the atlas, -Y at the four corners.
//   hemi-octahedral: +Y at the centre, the horizon (y = 0) on the border;
//                    directions below the horizon are clamped onto it.
//
// On the full octahedron the border folds: grid vertices (1, t) and (1, -t)
// (and likewise on the other three edges, and all four corners) are the same
// direction. Both tiles are baked; EncodeFrame returns the lowest-numbered
// of them, and CanonicalFrame says which frame a duplicate repeats.
//
// All functions are pure and thread-safe.
#ifndef IMPOSTOR_COMMON_ATLAS_ATLAS_LAYOUT_H_
#define IMPOSTOR_COMMON_ATLAS_ATLAS_LAYOUT_H_

#include <cstdint>
#include <string>
#include <string_view>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "absl/status/statusor.h"

namespace impostor {

enum class LayoutKind {
  kOctahedral,        // full sphere
  kHemiOctahedral,    // upper hemisphere (y >= 0)
  kAzimuthElevation,  // full sphere, azimuth columns x elevation rows
  kRingTop,           // K horizontal views + 1 from straight above
  kBillboard,         // traditional 3x3: 8 side views + 1 top view
};

// "octahedral", "hemi-octahedral", "azimuth-elevation", "ring-top",
// "billboard", as in the manifest and the CLI.
std::string_view LayoutName(LayoutKind kind);
// INVALID_ARGUMENT naming the accepted values if `name` is not a layout.
absl::StatusOr<LayoutKind> ParseLayout(std::string_view name);

struct FrameCoord {
  int col = 0;  // 0 .. frames-1, left to right
  int row = 0;  // 0 .. frames-1, top to bottom
  friend bool operator==(const FrameCoord&, const FrameCoord&) = default;
};

// Octahedral square [-1,1]^2 <-> unit direction.
glm::vec3 OctahedralToDirection(glm::vec2 oct);
glm::vec2 DirectionToOctahedral(glm::vec3 direction);
glm::vec3 HemiOctahedralToDirection(glm::vec2 oct);
glm::vec2 DirectionToHemiOctahedral(glm::vec3 direction);

glm::vec3 LayoutToDirection(LayoutKind kind, glm::vec2 oct);
glm::vec2 DirectionToLayout(LayoutKind kind, glm::vec3 direction);

// Grid position of a direction, in frame units: (0,0) is frame (0,0),
// (frames-1, frames-1) the opposite corner. Fractional between frames.
glm::vec2 DirectionToGrid(LayoutKind kind, int frames, glm::vec3 direction);

// Direction of the camera that bakes frame `frame` (unit length).
glm::vec3 FrameDirection(LayoutKind kind, int frames, FrameCoord frame);

// Nearest frame to a direction. Ties (a direction exactly half-way between
// grid vertices) round up, in every caller. On the octahedron's folded border
// the lowest-numbered duplicate is returned.
FrameCoord EncodeFrame(LayoutKind kind, int frames, glm::vec3 direction);

// The lowest-numbered frame showing the same view as `frame` (itself unless
// `frame` is a duplicate on the octahedron's folded border).
FrameCoord CanonicalFrame(LayoutKind kind, int frames, FrameCoord frame);

inline int FrameIndex(int frames, FrameCoord f) { return f.row * frames + f.col; }
inline FrameCoord FrameFromIndex(int frames, int index) {
  return {index % frames, index / frames};
}

// ---------------------------------------------------------------------------
// Every layout, by frame index. The functions above are the grid form of the
// two octahedral layouts; the ones below cover all five and are what the
// baker, the manifest and the runtime use.
//
// azimuth-elevation (after the Cinevva article): N x N frames, N odd.
//   az = atan2(d.x, d.z) in [0, 2 pi), el = asin(d.y).
//   Column c is azimuth c * 2 pi / N (column 0 looks from +Z, the front);
//   row r is elevation 90 - (r + 0.5) * 180 / N degrees (row 0 at the top
//   of the image is the highest). An odd N puts the middle row at exactly
//   0 degrees, where most views come from; an even N has no horizontal row
//   and is refused by the request validation.
// ring-top: K = ring_views frames at elevation 0, frame k at azimuth
//   k * 2 pi / K, then frame K looking from straight above (+Y).
// billboard: ring-top with K = 8 (every 45 degrees) in a 3 x 3 atlas.
// Tiles: frame i sits in tile (i % side, i / side) of a side x side grid
// (GridSide); ring-top's tiles past its last frame stay empty.
// Picking (NearestFrame): the frame whose direction is nearest in angle,
// ties to the lowest index. On the octahedral layouts it is the nearest of
// the four vertices of the grid cell the direction falls in (which is the
// nearest frame overall, up to a few hundredths of a degree across the
// folded border); EncodeFrame instead rounds in the octahedral square.

struct ViewLayout {
  LayoutKind kind = LayoutKind::kOctahedral;
  // Octahedral, hemi-octahedral, azimuth-elevation: frames per axis (N).
  int frames = 0;
  // Ring-top: horizontal views (K). Billboard: 8. Others: 0.
  int ring_views = 0;
};

inline constexpr int kBillboardRingViews = 8;

// The layouts a bake can produce (bake_request.h and layout_parameters.h
// validate requests against these; the runtime validates manifests).
inline constexpr uint32_t kMinFrames = 2;   // frames per axis of the grid layouts
inline constexpr uint32_t kMaxFrames = 64;  // (azimuth-elevation: odd, 3..63)
inline constexpr uint32_t kMinRingViews = 3;   // ring-top's horizontal views K
inline constexpr uint32_t kMaxRingViews = 64;

// True when `layout` is one a bake produces: grid layouts with kMinFrames..
// kMaxFrames frames per axis (odd for azimuth-elevation), ring-top with
// kMinRingViews..kMaxRingViews horizontal views, and billboard. The
// frame math below assumes it; a runtime reading a manifest checks it first.
bool IsBakeableLayout(const ViewLayout& layout);

// Frames that are baked: N * N, or K + 1 for ring-top and billboard.
int FrameCount(const ViewLayout& layout);
// Tiles per atlas side: N, or ceil(sqrt(K + 1)) for ring-top, 3 for billboard.
int GridSide(const ViewLayout& layout);
// Direction (unit, centre -> camera) of frame `index`, 0 <= index < FrameCount.
glm::vec3 FrameDirectionAt(const ViewLayout& layout, int index);
// The frame shown for a view from `direction` (need not be unit length, must
// not be zero); canonical on the octahedral fold.
int NearestFrame(const ViewLayout& layout, glm::vec3 direction);
// Lowest-numbered frame showing the same view as `index` (octahedral fold).
int CanonicalFrameIndex(const ViewLayout& layout, int index);
// Tile of frame `index` in the side x side grid of tiles.
inline FrameCoord FrameTile(const ViewLayout& layout, int index) {
  return FrameFromIndex(GridSide(layout), index);
}

// Azimuth-elevation in radians: az in [0, 2 pi), el in [-pi/2, pi/2].
glm::vec2 DirectionToAzimuthElevation(glm::vec3 direction);
glm::vec3 AzimuthElevationToDirection(float azimuth, float elevation);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_ATLAS_ATLAS_LAYOUT_H_
