// CPU reference renderer for surfel clouds and the quality figures of a
// bake. Points are drawn as the runtime draws them (Meep engine,
// VoxelImpostorShaderV0): camera-facing squares of side point_diameter,
// unlit albedo, nearest splat wins; here through a frame camera of
// common/atlas/frame_camera.h (orthographic, view square = the bounding sphere's
// diameter). A splat smaller than a pixel still covers the pixel its centre
// falls in, as a GPU point of at least one pixel does.
//
// Pure functions; thread-safe.
#ifndef IMPOSTOR_WORKER_SURFELS_SPLAT_RENDERER_H_
#define IMPOSTOR_WORKER_SURFELS_SPLAT_RENDERER_H_

#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

#include "common/atlas/frame_camera.h"
#include "worker/gpu/atlas_renderer.h"
#include "worker/surfels/surfel.h"

namespace impostor {

// `size` x `size` pixels, row 0 = the camera's up side.
struct SplatImage {
  int size = 0;
  std::vector<uint8_t> coverage;  // 1 covered, 0 empty
  std::vector<glm::vec3> albedo;  // linear; 0 where empty
};

// Renders `points` as squares of side `diameter` (scene units) seen by
// `camera` framing `sphere`, into a size x size image (camera.tile is
// ignored).
SplatImage RenderSplats(const std::vector<Surfel>& points, float diameter, const FrameCamera& camera,
                        const BoundingSphere& sphere, int size);

struct ViewComparison {
  size_t splat_pixels = 0;      // covered by the splats
  size_t reference_pixels = 0;  // covered in the reference
  size_t both = 0;
  size_t either = 0;
  double albedo_squared_error = 0;  // sum over `both` pixels and 3 channels, linear
  double Iou() const { return either == 0 ? 1.0 : static_cast<double>(both) / either; }
};

// Compares a splat image with one tile of a baked atlas (coverage: albedo
// alpha >= 128; albedo decoded from sRGB). The tile must be image.size on a
// side and lie inside the atlas.
ViewComparison CompareWithAtlasTile(const SplatImage& image, const AtlasImages& reference, const TileRect& tile);

// PSNR in dB for a mean squared error of values in 0..1; 99 for a perfect
// match.
double PsnrDb(double mean_squared_error);

// `count` view directions spread evenly over the sphere (a Fibonacci
// lattice), or over the upper hemisphere (y >= 0.05) when `upper_only`;
// they fall between the octahedral frames' directions, which makes them
// held-out views for judging a capture.
std::vector<glm::vec3> HeldOutDirections(int count, bool upper_only);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_SURFELS_SPLAT_RENDERER_H_
