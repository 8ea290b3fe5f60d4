// The worker's bake pipeline for surfel (voxel) impostors, by stage:
//   load (glTF -> Scene) -> capture (the atlas renderer, every canonical
//   frame of the layout) -> read back (covered texels -> samples,
//   worker/surfels/atlas_samples) -> cluster (voxel grid sized to the point
//   budget, worker/surfels/voxel_binning) -> judge (CPU splats against the
//   mesh from held-out views, worker/surfels/splat_renderer) -> write (point
//   buffer, .ply, manifest.json into the output directory).
// Like BakeAtlas it knows nothing of gRPC; the worker loop uploads every file
// the manifest's `maps` list, plus manifest.json.
//
// Thread-safety: one bake per AtlasRenderer at a time.
#ifndef IMPOSTOR_WORKER_BAKE_SURFEL_BAKE_H_
#define IMPOSTOR_WORKER_BAKE_SURFEL_BAKE_H_

#include <atomic>
#include <vector>

#include "absl/status/statusor.h"
#include "impostor/v1/types.pb.h"
#include "worker/bake/atlas_bake.h"
#include "worker/gpu/atlas_renderer.h"
#include "worker/scene/scene.h"
#include "worker/surfels/surfel.h"
#include "worker/surfels/voxel_binning.h"

namespace impostor {

// File names in the result directory.
inline constexpr char kSurfelBufferFile[] = "surfels.bin";
inline constexpr char kSurfelPlyFile[] = "surfels.ply";

// Held-out views the quality pass compares, and the bounds of their side in
// pixels (chosen so that a pixel is about one voxel: the distance at which
// the cloud is meant to be seen).
inline constexpr int kQualityViews = 8;
inline constexpr int kMinQualityPixels = 32;
inline constexpr int kMaxQualityPixels = 256;

struct SurfelQualityFigures {
  int views = 0;
  int view_pixels = 0;
  double iou_mean = 0;
  double iou_min = 0;
  double albedo_psnr_db = 0;
};

// A baked cloud in memory.
struct SurfelCloudResult {
  std::vector<Surfel> points;  // Morton order, <= the budget
  BoundingSphere sphere;       // the mesh's, which framed the capture
  BudgetFit fit;
  size_t sample_count = 0;
  float voxel_size = 0;
  float point_diameter = 0;    // voxel_size * sqrt(2)
  SurfelQualityFigures quality;
  RenderTimings capture_timings;
  double cluster_seconds = 0;
  double quality_seconds = 0;
};

// Captures `scene` with the layout, frames and resolution of `parameters`
// (normalised, product PRODUCT_SURFELS) and clusters the samples to its
// point_budget. INVALID_ARGUMENT when the mesh has no extent or no texel of
// the capture is covered; CANCELLED when `cancelled` turns true between
// stages; the renderer's errors otherwise. `progress` is called with
// fractions in [0.15, 0.9].
absl::StatusOr<SurfelCloudResult> BakeSurfelCloud(const Scene& scene, const v1::BakeParameters& parameters,
                                                  AtlasRenderer& renderer, const BakeProgress& progress,
                                                  const std::atomic<bool>& cancelled);

// The whole pipeline for a request whose parameters have product
// PRODUCT_SURFELS: writes surfels.bin, surfels.ply and manifest.json into
// request.output_dir. Errors as BakeSurfelCloud, plus the loader's
// INVALID_ARGUMENT for a bad mesh and INTERNAL when a file cannot be written.
absl::StatusOr<AtlasBakeOutput> BakeSurfels(const AtlasBakeRequest& request, AtlasRenderer& renderer,
                                            const BakeProgress& progress, const std::atomic<bool>& cancelled);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_BAKE_SURFEL_BAKE_H_
