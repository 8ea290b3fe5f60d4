// The bake's quality pass: how faithful an atlas impostor is to its mesh.
//
// The mesh is rendered by the bake's own renderer (unlit albedo, the same
// orthographic camera convention as the bake, common/atlas/frame_camera.h) from K
// held-out view directions that are not baked frames, and the impostor is
// reconstructed for the very same cameras by the shipped runtime shader on a
// GPU, or the CPU reference renderer (common/runtime/reference_renderer.h)
// on a CPU device (ImpostorViewsOn), i.e. exactly as a game would draw it.
// Both sides are unlit, so every difference is the impostor's. The mesh
// views are supersampled (kReferenceSupersampling, filtered down on the
// device, textures sampled as a supersampled bake samples them), so the
// reference pixel is its area, not one point of it: a 1-sample view held
// texture and normal-map detail finer than a pixel can show, which no
// reconstruction matches and which counted as the impostor's colour error
// (DamagedHelmet hemi-octahedral 12x12 at 2048 px: shared PSNR 22.1 dB with
// 1 sample, 27.3 dB with 3x3; SSIM 0.863 -> 0.956). The factor is odd so a
// pixel is covered iff more than half its samples are: an even factor ties
// at exactly half on many edge pixels and grew the silhouette by half a
// pixel all round (2x2 cut BoxTextured's worst-view IoU 0.987 -> 0.960),
// where 3x3 and 1 sample agree. Each pair
// is measured with common/quality/image_metrics.h and the figures are
// summarised (min, mean) into v1::AtlasQuality.
//
// Every view is measured in options.reconstruction (depth by default) and,
// with also_plain, in plain mode too (AtlasQuality.plain).
//
// Pop: the camera orbits the object at a fixed elevation in 1 degree steps;
// for each step, the change of the reconstruction (MeanAbsoluteAlbedoChange
// between neighbouring steps) is divided by the mesh's own change over the
// same step, and the largest ratio is reported (1.0 = as smooth as the mesh).
// A step where the mesh hardly changes (a symmetric object) would make the
// ratio explode on noise, so the mesh's change is floored at a quarter of its
// mean change over the orbit and at half an 8-bit level (PopRatio).
// Pop as a player sees it (AtlasQuality.pop_antialiased, issue 43; the figure
// targets are set on): the same formula with both orbits supersampled 3 x 3,
// what a game with MSAA or TAA shows. The one-sample figure (`pop`) is kept
// beside it, but the mesh's own one-sample aliasing can score 4 against its
// antialiased orbit (WaterBottle), so no rendering could meet a target on it.
// Pop reference (options.pop_references, for bench/quality_table): that
// "antialiased mesh" figure, the mesh's orbit supersampled 3 x 3 against its
// one-sample orbit, to tell a reconstruction's jumps from the formula's limits.
// IoU reference (the same option): the mesh's held-out views drawn with one
// sample per pixel, as the impostor's are, against its 3 x 3 views. A
// silhouette made mostly of edges (a tree of leaves and twigs) loses IoU to
// sampling alone; this is what the mesh itself scores so.
//
// Good-for sizes (good_for_size.h): the held-out views drawn again at twice
// the pass's size and shrunk to a ladder of on-screen sizes; the largest
// size at which the impostor meets its targets is AtlasQuality.good_up_to_pixels.
//
// Held-out directions: a spherical Fibonacci set over the layout's domain
// (the whole sphere for octahedral and azimuth-elevation, the upper
// hemisphere for hemi-octahedral, elevations 0..60 degrees for ring-top and
// billboard, which are drawn from near the horizon),
// rotated by a hash of the cache key, so that they are spread evenly,
// deterministic per bake and unrelated to the frame grid; any that lands
// within kMinDegreesFromFrame of a baked frame is nudged away.
//
// Thread-safety: one pass per AtlasRenderer at a time (the renderer's rule).
#ifndef IMPOSTOR_WORKER_BAKE_QUALITY_PASS_H_
#define IMPOSTOR_WORKER_BAKE_QUALITY_PASS_H_

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <glm/vec3.hpp>

#include "absl/status/statusor.h"
#include "common/atlas/atlas_layout.h"
#include "common/quality/image_metrics.h"
#include "common/runtime/reference_renderer.h"
#include "impostor/v1/types.pb.h"
#include "worker/bake/quality_views.h"
#include "worker/gpu/atlas_renderer.h"
#include "worker/scene/scene.h"

namespace impostor {

// Default number of held-out views (BakeParameters.quality_views unset).
inline constexpr int kDefaultQualityViews = 16;
// Upper limit of BakeParameters.quality_views.
inline constexpr int kMaxQualityViews = 256;
// The held-out mesh views' supersampling factor (see the top of this file).
// The pop orbit's mesh views are not supersampled: pop compares the
// impostor's change between steps with the mesh's, and both are drawn with
// one sample per pixel, as a game draws them (measured: a 3x3 orbit raised
// Duck's pop 1.70 -> 2.03 by smoothing only the mesh side).
inline constexpr int kReferenceSupersampling = 3;
// No held-out direction is closer than this to a baked frame's direction.
inline constexpr float kMinDegreesFromFrame = 1.0f;

// The side-by-side image of the worst view (manifest map semantic and file).
inline constexpr char kQualityWorstViewSemantic[] = "quality_worst_view";
inline constexpr char kQualityWorstViewFile[] = "quality_worst_view.png";

// Who draws the impostor's side of every view: the shipped runtime shader on
// the bake's device (AtlasRenderer::UploadImpostor), or the CPU reference
// renderer on all cores. The two draw the same pixels up to float ties
// (tests/runtime/glsl_runtime_test.cc, tests/quality). kAuto: the device
// unless it is a CPU device (lavapipe), where the shader runs ~3 x slower
// than the C++ on the same cores; the CPU too when the upload fails (logged).
enum class ImpostorViewsOn { kAuto, kCpu, kDevice };

struct QualityPassOptions {
  int views = kDefaultQualityViews;  // held-out views, 1..kMaxQualityViews
  // Side of each compared view. The bake uses min(128, resolution / 8):
  // the same for every frame count at one resolution, and never beyond the
  // largest tile (8 frames) the atlas could have. The orbit uses at most
  // view_pixels too.
  int view_pixels = 128;
  // Pop orbit: `orbit_steps` views, 360 / orbit_steps degrees apart, at
  // `orbit_elevation_deg` above the horizon, `orbit_pixels` on a side
  // (small: the pop is about changes, not detail). 0 steps = no pop.
  int orbit_steps = 360;
  // Steps measured: 0 (or >= orbit_steps) = every step of the orbit;
  // otherwise `orbit_pairs` steps spread evenly around it (each still one
  // 360 / orbit_steps degree step), which renders 2 * orbit_pairs views
  // instead of orbit_steps. 36 (every 10 degrees) keeps the pass cheap with
  // the depth reconstruction, about 10 x plain's cost per pixel.
  int orbit_pairs = 36;
  int orbit_pixels = 64;
  float orbit_elevation_deg = 20.0f;
  BlendMode blend = BlendMode::kTriangle3;
  // The runtime reconstruction measured (the manifest's headline figures)
  // and whether the same views are also measured in plain mode
  // (AtlasQuality.plain, with its own pop orbit of the impostor).
  Reconstruction reconstruction = Reconstruction::kDepth;
  bool also_plain = true;
  // Where to write the worst view side by side (mesh | impostor |
  // difference); empty = not written.
  std::filesystem::path worst_view_png;
  // Where to write every held-out view (quality_views.h); empty = not written.
  std::filesystem::path views_dir;
  // Measure at `views` of the baked frames' own directions instead of
  // held-out ones (bench/quality_table --on-frames): there every
  // reconstruction returns the frame itself, so what differs from the mesh
  // is what the atlas lacks (its tiles' resolution), the ceiling of the
  // held-out figures. Not for bakes: the manifest's views are held out.
  bool on_frame_directions = false;
  // Pop as a player sees it (AtlasQuality.pop_antialiased): the mesh's
  // orbit and the headline reconstruction's again, both at 3 x 3 samples.
  bool pop_antialiased = true;
  // Also measure the pop references (top of this file). Not for bakes: the
  // antialiased mesh's orbit against its one-sample orbit.
  bool pop_references = false;
  // Good-for sizes (good_for_size.h, AtlasQuality.sizes and
  // good_up_to_pixels): the held-out views drawn again at this size (mesh at
  // 3 x 3) and shrunk to each size of GoodForLadder; 0 = not measured.
  // 8..1024 otherwise.
  int good_for_top_pixels = 0;
  v1::QualityGate good_for_targets;  // GoodForTargets(the bake's parameters)
  ImpostorViewsOn impostor_views_on = ImpostorViewsOn::kAuto;
};

// What a measuring tool may change in a bake's pass (AtlasBakeRequest);
// the defaults are the bake's own rules.
struct QualityPassOverrides {
  int view_pixels = 0;  // > 0: held-out views this size instead of min(128, resolution / 8)
  bool on_frame_directions = false;  // QualityPassOptions::on_frame_directions
  bool pop_references = false;       // QualityPassOptions::pop_references
  // >= 0: QualityPassOptions::good_for_top_pixels (0 = no sizes); -1 = the
  // bake's rule (twice the pass's view size).
  int good_for_top_pixels = -1;
  ImpostorViewsOn impostor_views_on = ImpostorViewsOn::kAuto;
};

struct QualityPassResult {
  v1::AtlasQuality quality;
  std::vector<glm::vec3> directions;  // the held-out views, quality.views of them
  std::vector<ViewMetrics> per_view;  // same order
  std::vector<ViewMetrics> plain_per_view;  // same order; empty unless also_plain
  std::vector<QualityViewsFile> view_files;  // written into views_dir
  double seconds = 0;        // the whole pass
  double views_seconds = 0;  // held-out views: render both sides, measure
  double pop_seconds = 0;    // the orbit
  double pop_antialiased_seconds = 0;  // of which the 3 x 3 orbits (pop_antialiased)
  double sizes_seconds = 0;  // the good-for sizes
  bool impostor_views_on_device = false;  // who drew them (ImpostorViewsOn)
  // With options.pop_references and an orbit (else -1): the antialiased
  // mesh's pop reference; with pop_antialiased or pop_references,
  // quality.pop_antialiased again.
  double pop_antialiased_mesh = -1;
  double pop_antialiased = -1;
  // With options.pop_references (else -1): the IoU reference (top of this
  // file), mean and worst over the held-out views.
  double one_sample_mesh_iou_mean = -1;
  double one_sample_mesh_iou_min = -1;
};

// `count` held-out view directions (unit, sphere centre -> camera) for an
// atlas of `frames` x `frames` in `layout`, deterministic in `cache_key`;
// none within kMinDegreesFromFrame of a frame direction.
std::vector<glm::vec3> HeldOutViewDirections(LayoutKind layout, int frames, std::string_view cache_key, int count);
// Any layout (ring-top needs its ring_views).
std::vector<glm::vec3> HeldOutViewDirections(const ViewLayout& layout, std::string_view cache_key, int count);

// Runs the pass on an atlas held in memory. INVALID_ARGUMENT for options out
// of range; the renderer's errors otherwise.
absl::StatusOr<QualityPassResult> MeasureAtlasQuality(const Scene& scene, const ImpostorAtlas& atlas,
                                                      std::string_view cache_key, const QualityPassOptions& options,
                                                      AtlasRenderer& renderer);

// Whether the reference renderer can draw a layout (all of them now).
bool QualityPassSupports(LayoutKind layout);

// The bake's hook (worker/bake/atlas_bake.cc), called with the maps as
// written (dilated): runs the pass with parameters.quality_views views (unset
// = kDefaultQualityViews; 0, or a layout QualityPassSupports refuses: nothing
// is added), writes kQualityWorstViewFile into `dir`, appends it to
// manifest->maps and fills manifest->quality. Takes the maps over (they are
// not needed after writing). Logs the pass's figures and time.
absl::Status AddAtlasQuality(const Scene& scene, const BoundingSphere& sphere, const std::vector<FrameCamera>& cameras,
                             AtlasImages&& maps, const v1::BakeParameters& parameters, const std::string& cache_key,
                             const std::filesystem::path& dir, AtlasRenderer& renderer, v1::Manifest* manifest,
                             const QualityPassOverrides& overrides = {});

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_BAKE_QUALITY_PASS_H_
