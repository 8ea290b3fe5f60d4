// Image metrics comparing two renders of the same object from the same
// camera: the mesh as the baker draws it against an impostor reconstructed
// by a runtime (or cards, or surfels). Pure functions over plain pixels in
// the atlas maps' encodings (worker/gpu/atlas_renderer.h, AtlasImages):
//   albedo_alpha  RGBA8, RGB = sRGB-encoded base colour, A = coverage
//   normal_depth  RGBA16, RGB = unit normal * 0.5 + 0.5, A = depth
//                 (1 - dot(p - c, d) / r) / 2, so one unit of A is 2 radii.
// A pixel is covered when its alpha is >= 128 (the bake writes 0 or 255;
// a filtered reconstruction may write in between).
//
// Where only one side covers a pixel, colour metrics see that side's colour
// against black: both images are composited over black (premultiplied by
// coverage), so a silhouette miss costs its full colour and a pixel neither
// side covers costs nothing and is not counted. Geometry metrics (normal,
// depth) use only pixels both sides cover; silhouette misses are IoU's job.
//
// SSIM is Wang, Bovik, Sheikh & Simoncelli, "Image Quality Assessment: From
// Error Visibility to Structural Similarity", IEEE TIP 13(4), 2004: on
// luminance (Rec. 601 weights of the sRGB-encoded values, as the authors'
// reference implementation does with rgb2gray), an 11 x 11 circular-symmetric
// Gaussian window with sigma 1.5, K1 = 0.01, K2 = 0.03, L = 1. Windows are
// clipped at the image border (weights renormalised over pixels inside), and
// the SSIM map is averaged over the union of both silhouettes.
//
// Thread-safe; no hidden state.
#ifndef IMPOSTOR_COMMON_QUALITY_IMAGE_METRICS_H_
#define IMPOSTOR_COMMON_QUALITY_IMAGE_METRICS_H_

#include <cstdint>
#include <span>

namespace impostor {

// A borrowed view of one image pair's pixels, width * height * 4 values
// each, rows top to bottom. normal_depth may be empty (no geometry metrics).
struct ViewPixels {
  int width = 0;
  int height = 0;
  std::span<const uint8_t> albedo_alpha;
  std::span<const uint16_t> normal_depth;
};

// PSNR reported for identical images (and for nothing to compare), dB:
// the top of QualityGate.min_psnr_db's range.
inline constexpr double kMaxPsnrDb = 100.0;

// Everything measured for one view pair.
struct ViewMetrics {
  int64_t union_pixels = 0;  // covered by either side
  int64_t both_pixels = 0;   // covered by both
  // |A n B| / |A u B|; 1 when neither covers anything.
  double iou = 1.0;
  // Over the union, composited over black, peak 1 (255 levels), capped at
  // kMaxPsnrDb: colour and silhouette misses in one figure (the manifest's
  // albedo_psnr_union_db_*).
  double albedo_psnr_db = kMaxPsnrDb;
  // Mean SSIM over the union, -1..1 (1 = identical; albedo_ssim_union_*).
  double albedo_ssim = 1.0;
  // Colour fidelity alone: PSNR over the pixels both cover (peak 1, capped
  // at kMaxPsnrDb; 0 when the silhouettes do not overlap at all), and SSIM
  // with every window restricted to those pixels, averaged over them.
  double albedo_psnr_shared_db = kMaxPsnrDb;
  double albedo_ssim_shared = 1.0;
  // Silhouette boundary error, pixels: the distance from every boundary
  // pixel of one silhouette to the nearest boundary pixel of the other, both
  // ways; mean and max (the symmetric Hausdorff distance). Boundary pixels:
  // covered pixels with an uncovered 4-neighbour or on the image border.
  double boundary_error_px_mean = 0.0;
  double boundary_error_px_max = 0.0;
  // Angle between the two normals over pixels both cover, degrees; 0 when
  // no pixel is covered by both.
  double normal_error_deg_mean = 0.0;
  double normal_error_deg_max = 0.0;
  // |depth difference| over pixels both cover, as a fraction of the
  // bounding-sphere radius.
  double depth_error_mean = 0.0;
  double depth_error_max = 0.0;
};

// All metrics of `test` against `reference`. The two must have the same size
// (asserted). Geometry metrics are 0 when either lacks normal_depth.
ViewMetrics CompareViews(const ViewPixels& reference, const ViewPixels& test);

// The single metrics, as CompareViews computes them.
double SilhouetteIou(const ViewPixels& a, const ViewPixels& b);

// SilhouetteIou outside `mesh`'s uncertain edge (issue 43's good-for
// sizes): pixels where the mesh's coverage is at least 1/3 and below 2/3
// are left out of both the intersection and the union. Those are pixels the
// mesh's own samples split near the 0.5 cut, which another sampling as
// valid (an impostor's filtered texels) puts on either side; at 32 px they
// are much of a silhouette a dozen pixels wide, at 256 px a sliver. A
// disagreement anywhere else counts as in SilhouetteIou. 1 when nothing
// is left to compare.
double SilhouetteIouOutsideEdge(const ViewPixels& mesh, const ViewPixels& test);
double AlbedoPsnrDb(const ViewPixels& a, const ViewPixels& b);
double AlbedoSsim(const ViewPixels& a, const ViewPixels& b);
double AlbedoPsnrSharedDb(const ViewPixels& a, const ViewPixels& b);
double AlbedoSsimShared(const ViewPixels& a, const ViewPixels& b);
struct BoundaryError {
  double mean_px = 0.0;  // 0 when neither covers anything
  double max_px = 0.0;   // the image diagonal when only one side covers
};
BoundaryError SilhouetteBoundaryError(const ViewPixels& a, const ViewPixels& b);

// Mean absolute difference of the colours composited over black, per channel
// on a 0..1 scale, averaged over the union of both silhouettes (0 when
// neither covers anything): how much an image changes from `a` to `b`. The
// pop metric compares this change between neighbouring orbit steps of the
// reconstruction with the mesh's.
double MeanAbsoluteAlbedoChange(const ViewPixels& a, const ViewPixels& b);

// Pop: the largest ratio, step by step, of `changes` (a rendering's
// MeanAbsoluteAlbedoChange between neighbouring orbit steps) to the mesh's
// own change over the same step, `mesh_changes` (same length). A step where
// the mesh hardly changes (a symmetric object) would make the ratio explode
// on noise, so the mesh's change is floored at a quarter of its mean over
// the orbit and at half an 8-bit level. 0 for empty input.
// The ratio rewards a rendering that changes in the same steps as the mesh:
// one that changes as much in total, but evenly, scores up to 4 where the
// mesh's one-sample-per-pixel orbit has quiet steps (PopRatio's test).
double PopRatio(std::span<const double> changes, std::span<const double> mesh_changes);

// Turns a mean squared error on a 0..1 scale into PSNR in dB, capped at
// kMaxPsnrDb (so MSE 0 gives the cap, never infinity).
double PsnrFromMse(double mse);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_QUALITY_IMAGE_METRICS_H_
