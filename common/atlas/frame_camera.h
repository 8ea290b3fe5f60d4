// The orthographic camera that bakes one atlas frame, and the pixel
// rectangle (tile) it covers in the atlas. Everything a consumer needs to
// rebuild a frame's camera is in the manifest's `views` list; this file is
// the one place that derives those values.
//
// Camera of a frame with direction d (unit, sphere centre -> camera):
//   up     = the world up (+Y) made orthogonal to d; for views within ~0.01
//            degrees of straight up or down, up = -Z (looking down) or +Z
//            (looking up).
//   right  = cross(up, d)
//   It sits at centre + d * radius looking at the centre; its view square is
//   the sphere's diameter on a side, near plane at distance 0, far at 2r.
// A point p lands at
//   s = dot(p - c, right) / r, t = dot(p - c, up) / r   (both in [-1, 1])
//   pixel x = tile.x + (s + 1) / 2 * tile.w
//   pixel y = tile.y + (1 - t) / 2 * tile.h            (row 0 = camera up)
//   depth   = (1 - dot(p - c, d) / r) / 2               (0 nearest, 1 farthest)
#ifndef IMPOSTOR_COMMON_ATLAS_FRAME_CAMERA_H_
#define IMPOSTOR_COMMON_ATLAS_FRAME_CAMERA_H_

#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "common/atlas/atlas_layout.h"

namespace impostor {

struct BoundingSphere {
  glm::vec3 center{0.0f};
  float radius = 0.0f;
};

struct TileRect {
  int x = 0, y = 0, width = 0, height = 0;  // pixels, y = 0 at the top row
};

struct FrameCamera {
  int index = 0;          // row * frames + col
  FrameCoord frame;
  glm::vec3 direction{0.0f, 0.0f, 1.0f};
  glm::vec3 up{0.0f, 1.0f, 0.0f};
  glm::vec3 right{1.0f, 0.0f, 0.0f};
  TileRect tile;
};

// Up vector for a view direction, by the rule above.
glm::vec3 CameraUpFor(glm::vec3 direction);

// Side of one tile, padded for mipmaps: resolution / frames rounded down to
// a multiple of 2^L, where L = MipSafeLevels(...) is the deepest mip level
// whose tiles are still at least kMipSafeTilePixels wide. Tiles then start
// on multiples of 2^L, so every texel of mip levels 0..L lies inside one
// tile: down to a 16 px tile, no mip level mixes neighbouring frames (each
// tile is dilated to its edges, so its own colour fills its whole square).
// Tiles start at the top-left corner; the remainder at the right and bottom
// (resolution - frames * tile, under 2^L + frames pixels) stays empty.
int TileSize(int resolution, int frames);

inline constexpr int kMipSafeTilePixels = 16;
// L above: floor(log2((resolution / frames) / 16)), at least 0.
int MipSafeLevels(int resolution, int frames);

// Block-compressed maps (KTX2): the tile side as TileSize, but rounded down
// to a multiple of 4 * 2^L, so every mip level 0..L has tiles whose side is
// a multiple of 4 px and no 4x4 block straddles two frames. Still at least
// 16 px at level L. An atlas of resolution frames * BlockAlignedTileSize
// has exactly this TileSize (the server normalises KTX2 requests to it).
int BlockAlignedTileSize(int resolution, int frames);

// All frames of an octahedral or hemi-octahedral atlas, index order.
std::vector<FrameCamera> AtlasCameras(LayoutKind kind, int frames, int resolution);

// All frames of any layout, index order: frame i in tile FrameTile(layout, i)
// of side TileSize(resolution, GridSide(layout)). `frame` holds the tile's
// grid position.
std::vector<FrameCamera> AtlasCameras(const ViewLayout& layout, int resolution);

// Vulkan clip-space transform (x right, y down, depth 0..1) for one frame's
// camera: clip = ViewProjection * vec4(p, 1) gives x = s, y = -t,
// z = depth as defined above, w = 1.
glm::mat4 FrameViewProjection(const FrameCamera& camera, const BoundingSphere& sphere);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_ATLAS_FRAME_CAMERA_H_
