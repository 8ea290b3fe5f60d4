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
#ifndef IMPOSTOR_COMMON_ATLAS_LAYOUT_H_
#define IMPOSTOR_COMMON_ATLAS_LAYOUT_H_

#include <cstdint>
#include <string>
#include <string_view>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "absl/status/statusor.h"

namespace impostor {

enum class LayoutKind {
  kOctahedral,      // full sphere
  kHemiOctahedral,  // upper hemisphere (y >= 0)
};

// "octahedral" / "hemi-octahedral", as in the manifest and the CLI.
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

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_ATLAS_LAYOUT_H_
