// A surfel cloud as a binary little-endian PLY (Turk, "The PLY Polygon File
// Format", 1994), so anyone can open a baked cloud in a point-cloud viewer
// (MeshLab, CloudCompare, Blender). Per vertex: float x y z, float nx ny nz,
// uchar red green blue (albedo encoded to 8-bit sRGB, as viewers display
// colours), float occlusion roughness metalness (extra properties viewers
// ignore). Pure function; thread-safe.
#ifndef IMPOSTOR_WORKER_SURFELS_PLY_WRITER_H_
#define IMPOSTOR_WORKER_SURFELS_PLY_WRITER_H_

#include <string>
#include <vector>

#include "worker/surfels/surfel.h"

namespace impostor {

inline constexpr char kPlyFormat[] = "ply_binary_le";

// The file's bytes. `comments` go into the header as "comment" lines
// (no newlines inside).
std::string EncodePly(const std::vector<Surfel>& points, const std::vector<std::string>& comments);

// Linear 0..1 -> 8-bit sRGB code (IEC 61966-2-1), clamped.
uint8_t LinearToSrgbByte(float linear);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_SURFELS_PLY_WRITER_H_
