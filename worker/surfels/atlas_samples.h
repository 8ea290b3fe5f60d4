// Turns a baked multi-view capture (the three atlas maps, before dilation)
// back into surface samples: every covered texel of a frame becomes one
// Surfel at the point the frame's camera saw, with the normal, linear albedo
// and ORM the baker wrote there. This is the read-back step of voxel
// impostors (Meep engine, VoxelImpostorBaker: "reads the atlas back to CPU
// and bins every opaque pixel").
//
// Unprojection inverts common/atlas/frame_camera.h: texel centre (x + 0.5, y + 0.5)
// of a tile gives s, t in [-1, 1], the 16-bit depth gives the distance
// along the view direction, so
//   p = c + r * (s * right + t * up + (1 - 2 * depth) * direction).
// The rasteriser sampled the mesh at exactly that texel centre, so p lies on
// the surface up to the depth's quantisation (r / 32768).
//
// Pure function; thread-safe.
#ifndef IMPOSTOR_WORKER_SURFELS_ATLAS_SAMPLES_H_
#define IMPOSTOR_WORKER_SURFELS_ATLAS_SAMPLES_H_

#include <vector>

#include "common/atlas/frame_camera.h"
#include "worker/gpu/atlas_renderer.h"
#include "worker/surfels/surfel.h"

namespace impostor {

// 8-bit sRGB code -> linear value (IEC 61966-2-1).
float SrgbByteToLinear(uint8_t code);

// Samples of every covered texel (albedo alpha >= 128) of every camera in
// `cameras`, in camera order, then row-major within a tile. Cameras whose
// tile lies outside the images are skipped. Frames that repeat another view
// (the octahedron's folded border) should be left out by the caller, or their
// texels count twice.
std::vector<Surfel> AtlasToSamples(const AtlasImages& atlas, const std::vector<FrameCamera>& cameras,
                                   const BoundingSphere& sphere);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_SURFELS_ATLAS_SAMPLES_H_
