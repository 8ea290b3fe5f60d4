// The image metrics on synthetic cases whose answer is known in closed form.
#include "common/quality/image_metrics.h"

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace impostor {
namespace {

// A test image: a size x size view with a covered rectangle of one colour,
// normal and depth.
struct Image {
  int size = 0;
  std::vector<uint8_t> albedo;
  std::vector<uint16_t> normal_depth;
  ViewPixels Pixels() const { return {size, size, albedo, normal_depth}; }
};

struct Rect {
  int x0, y0, x1, y1;  // half-open
};

Image MakeImage(int size, Rect covered, uint8_t r, uint8_t g, uint8_t b, uint16_t nx = 32768, uint16_t ny = 32768,
                uint16_t nz = 65535, uint16_t depth = 16384) {
  Image im;
  im.size = size;
  im.albedo.assign(static_cast<size_t>(size) * size * 4, 0);
  im.normal_depth.resize(static_cast<size_t>(size) * size * 4);
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const size_t i = (static_cast<size_t>(y) * size + x) * 4;
      const bool in = x >= covered.x0 && x < covered.x1 && y >= covered.y0 && y < covered.y1;
      im.normal_depth[i + 0] = im.normal_depth[i + 1] = im.normal_depth[i + 2] = 32768;
      im.normal_depth[i + 3] = 65535;
      if (!in) continue;
      im.albedo[i + 0] = r, im.albedo[i + 1] = g, im.albedo[i + 2] = b, im.albedo[i + 3] = 255;
      im.normal_depth[i + 0] = nx, im.normal_depth[i + 1] = ny, im.normal_depth[i + 2] = nz;
      im.normal_depth[i + 3] = depth;
    }
  }
  return im;
}

// A textured square (a checker of 4-pixel cells) so SSIM has structure.
Image MakeChecker(int size, Rect covered) {
  Image im = MakeImage(size, covered, 0, 0, 0);
  for (int y = covered.y0; y < covered.y1; ++y) {
    for (int x = covered.x0; x < covered.x1; ++x) {
      const size_t i = (static_cast<size_t>(y) * size + x) * 4;
      const uint8_t v = ((x / 4 + y / 4) % 2) ? 200 : 60;
      im.albedo[i] = v, im.albedo[i + 1] = v / 2, im.albedo[i + 2] = 255 - v;
    }
  }
  return im;
}

TEST(ImageMetricsTest, IdenticalImagesArePerfect) {
  const Image a = MakeChecker(64, {10, 12, 50, 40});
  const ViewMetrics m = CompareViews(a.Pixels(), a.Pixels());
  EXPECT_DOUBLE_EQ(m.iou, 1.0);
  EXPECT_DOUBLE_EQ(m.albedo_psnr_db, kMaxPsnrDb);
  EXPECT_NEAR(m.albedo_ssim, 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(m.normal_error_deg_mean, 0.0);
  EXPECT_DOUBLE_EQ(m.normal_error_deg_max, 0.0);
  EXPECT_DOUBLE_EQ(m.depth_error_mean, 0.0);
  EXPECT_EQ(m.union_pixels, 40 * 28);
  EXPECT_EQ(m.both_pixels, 40 * 28);
}

TEST(ImageMetricsTest, EmptyImagesHaveNothingToDiffer) {
  const Image a = MakeImage(16, {0, 0, 0, 0}, 0, 0, 0);
  const ViewMetrics m = CompareViews(a.Pixels(), a.Pixels());
  EXPECT_DOUBLE_EQ(m.iou, 1.0);
  EXPECT_DOUBLE_EQ(m.albedo_psnr_db, kMaxPsnrDb);
  EXPECT_DOUBLE_EQ(m.albedo_ssim, 1.0);
  EXPECT_EQ(m.union_pixels, 0);
}

// A w x h square shifted by k pixels along x: intersection (w - k) h, union
// (w + k) h.
TEST(ImageMetricsTest, ShiftedSilhouetteGivesKnownIou) {
  struct Case {
    int w, h, k;
  };
  for (const Case c : {Case{20, 20, 1}, Case{20, 20, 5}, Case{30, 10, 10}, Case{16, 16, 16}}) {
    SCOPED_TRACE(::testing::Message() << "w=" << c.w << " h=" << c.h << " shift=" << c.k);
    const Image a = MakeImage(64, {5, 5, 5 + c.w, 5 + c.h}, 100, 100, 100);
    const Image b = MakeImage(64, {5 + c.k, 5, 5 + c.k + c.w, 5 + c.h}, 100, 100, 100);
    const double expected = static_cast<double>(std::max(0, c.w - c.k)) / (c.w + c.k);
    EXPECT_NEAR(SilhouetteIou(a.Pixels(), b.Pixels()), expected, 1e-12);
    const ViewMetrics m = CompareViews(a.Pixels(), b.Pixels());
    EXPECT_EQ(m.union_pixels, (c.w + c.k) * c.h);
    // Misses are composited over black: 2 k h of (w + k) h pixels differ by
    // 100 levels in every channel.
    const double mse = (2.0 * c.k * c.h) * std::pow(100.0 / 255.0, 2) / ((c.w + c.k) * c.h);
    EXPECT_NEAR(m.albedo_psnr_db, -10.0 * std::log10(mse), 1e-9);
  }
}

// A flat shift of d levels in every channel over the same silhouette:
// PSNR = 20 log10(255 / d).
// SilhouetteIouOutsideEdge: a 20 x 20 mesh square with a one-pixel ring at
// alpha 128 (coverage 1/2, inside the uncertain band), against an impostor
// that covers the square only: SilhouetteIou counts the 84 ring pixels as
// misses (400 / 484), the IoU outside the edge leaves them out (1). The ring
// at 200 (firm coverage) counts as before; a miss outside the ring (the
// impostor 2 pixels short on one side) counts whatever the ring is.
TEST(ImageMetricsTest, SilhouetteIouOutsideEdgeLeavesOutOnlyTheMeshsUncertainPixels) {
  auto mesh_with_ring = [](uint8_t ring) {
    Image im = MakeImage(32, {6, 6, 26, 26}, 10, 10, 10);
    for (int y = 5; y < 27; ++y) {
      for (int x = 5; x < 27; ++x) {
        if (x >= 6 && x < 26 && y >= 6 && y < 26) continue;
        im.albedo[(static_cast<size_t>(y) * 32 + x) * 4 + 3] = ring;
      }
    }
    return im;
  };
  const Image square = MakeImage(32, {6, 6, 26, 26}, 10, 10, 10);
  const Image short_square = MakeImage(32, {6, 6, 24, 26}, 10, 10, 10);
  for (auto [ring, plain, outside, outside_short] :
       {std::tuple{uint8_t{128}, 400.0 / 484.0, 1.0, 360.0 / 400.0},
        std::tuple{uint8_t{200}, 400.0 / 484.0, 400.0 / 484.0, 360.0 / 484.0},
        std::tuple{uint8_t{85}, 1.0, 1.0, 360.0 / 400.0},    // 1/3: in the band, and not covered
        std::tuple{uint8_t{170}, 400.0 / 484.0, 400.0 / 484.0, 360.0 / 484.0},  // 2/3: firm
        std::tuple{uint8_t{60}, 1.0, 1.0, 360.0 / 400.0}}) {
    const Image mesh = mesh_with_ring(ring);
    EXPECT_NEAR(SilhouetteIou(mesh.Pixels(), square.Pixels()), plain, 1e-12) << int(ring);
    EXPECT_NEAR(SilhouetteIouOutsideEdge(mesh.Pixels(), square.Pixels()), outside, 1e-12) << int(ring);
    EXPECT_NEAR(SilhouetteIouOutsideEdge(mesh.Pixels(), short_square.Pixels()), outside_short, 1e-12) << int(ring);
  }
  const Image empty = MakeImage(16, {0, 0, 0, 0}, 0, 0, 0);
  EXPECT_EQ(SilhouetteIouOutsideEdge(empty.Pixels(), empty.Pixels()), 1.0);
}

TEST(ImageMetricsTest, FlatColourShiftGivesKnownPsnr) {
  for (int d : {1, 2, 5, 16, 64}) {
    SCOPED_TRACE(::testing::Message() << "shift=" << d);
    const Image a = MakeImage(32, {4, 4, 28, 20}, 100, 120, 140);
    const Image b = MakeImage(32, {4, 4, 28, 20}, 100 + d, 120 + d, 140 + d);
    EXPECT_NEAR(AlbedoPsnrDb(a.Pixels(), b.Pixels()), 20.0 * std::log10(255.0 / d), 1e-9);
    EXPECT_DOUBLE_EQ(SilhouetteIou(a.Pixels(), b.Pixels()), 1.0);
  }
}

// SSIM sees structure: noise lowers it, losing the texture lowers it more.
TEST(ImageMetricsTest, SsimFallsWithStructureAndStaysBelowOne) {
  const Image a = MakeChecker(64, {8, 8, 56, 56});
  Image noisy = a;
  uint32_t state = 12345;
  for (size_t i = 0; i < noisy.albedo.size(); i += 4) {
    if (noisy.albedo[i + 3] == 0) continue;
    state = state * 1664525u + 1013904223u;
    const int n = static_cast<int>((state >> 24) % 61) - 30;
    for (int c = 0; c < 3; ++c) noisy.albedo[i + c] = static_cast<uint8_t>(std::clamp(noisy.albedo[i + c] + n, 0, 255));
  }
  const double ssim_noisy = AlbedoSsim(a.Pixels(), noisy.Pixels());
  EXPECT_LT(ssim_noisy, 0.95);
  EXPECT_GT(ssim_noisy, 0.3);
  // A flat grey patch against the checker loses the structure entirely.
  const Image flat = MakeImage(64, {8, 8, 56, 56}, 130, 65, 125);
  EXPECT_LT(AlbedoSsim(a.Pixels(), flat.Pixels()), ssim_noisy);
}

TEST(ImageMetricsTest, NormalAndDepthErrorsAreKnownAngleAndRadiusFraction) {
  // Normal +Z against normal rotated 90 degrees to +X; depth 0.25 vs 0.375
  // of the encoded range = 0.125 * 2 radii = 0.25 r.
  const Image a = MakeImage(16, {0, 0, 8, 8}, 50, 50, 50, 32768, 32768, 65535, 16384);
  const Image b = MakeImage(16, {0, 0, 8, 8}, 50, 50, 50, 65535, 32768, 32768, 24576);
  const ViewMetrics m = CompareViews(a.Pixels(), b.Pixels());
  EXPECT_NEAR(m.normal_error_deg_mean, 90.0, 0.01);
  EXPECT_NEAR(m.normal_error_deg_max, 90.0, 0.01);
  EXPECT_NEAR(m.depth_error_mean, 0.25, 1e-4);
  EXPECT_NEAR(m.depth_error_max, 0.25, 1e-4);
}

TEST(ImageMetricsTest, GeometryCountsOnlyPixelsBothCover) {
  // b covers more, with a wildly different normal outside a's square: only
  // the overlap counts, where both agree.
  const Image a = MakeImage(16, {0, 0, 8, 8}, 50, 50, 50);
  Image b = MakeImage(16, {0, 0, 16, 16}, 50, 50, 50, 65535, 32768, 32768);
  for (int y = 0; y < 8; ++y) {
    for (int x = 0; x < 8; ++x) {
      const size_t i = (static_cast<size_t>(y) * 16 + x) * 4;
      b.normal_depth[i] = 32768, b.normal_depth[i + 2] = 65535;
    }
  }
  const ViewMetrics m = CompareViews(a.Pixels(), b.Pixels());
  EXPECT_NEAR(m.normal_error_deg_max, 0.0, 1e-9);
  EXPECT_DOUBLE_EQ(m.iou, 64.0 / 256.0);
}

TEST(ImageMetricsTest, AlbedoChangeIsMeanAbsoluteDifferenceOverUnion) {
  const Image a = MakeImage(16, {0, 0, 8, 16}, 100, 100, 100);
  const Image b = MakeImage(16, {0, 0, 8, 16}, 110, 90, 100);
  EXPECT_NEAR(MeanAbsoluteAlbedoChange(a.Pixels(), b.Pixels()), (10.0 + 10.0 + 0.0) / 3.0 / 255.0, 1e-12);
  EXPECT_DOUBLE_EQ(MeanAbsoluteAlbedoChange(a.Pixels(), a.Pixels()), 0.0);
}

TEST(ImageMetricsTest, PopIsTheLargestStepRatioToTheMeshsFlooredChange) {
  // Same changes: 1.0. A step twice the mesh's: 2.0.
  const std::vector<double> mesh = {0.02, 0.04, 0.02, 0.04};
  EXPECT_DOUBLE_EQ(PopRatio(mesh, mesh), 1.0);
  EXPECT_DOUBLE_EQ(PopRatio(std::vector<double>{0.02, 0.04, 0.04, 0.04}, mesh), 2.0);
  // A quiet mesh step is floored at a quarter of the mesh's mean change
  // (0.03 / 4), not divided by its own 0.
  const std::vector<double> quiet = {0.0, 0.04, 0.04, 0.04};
  EXPECT_DOUBLE_EQ(PopRatio(std::vector<double>{0.015, 0.04, 0.04, 0.04}, quiet), 2.0);
  // ... and at half an 8-bit level.
  const std::vector<double> still = {0.0, 0.0, 0.0, 0.0004};
  EXPECT_DOUBLE_EQ(PopRatio(std::vector<double>{0.5 / 255.0, 0.0, 0.0, 0.0}, still), 1.0);
  EXPECT_DOUBLE_EQ(PopRatio(std::vector<double>{}, std::vector<double>{}), 0.0);
}

// The limit quality_pass.h's pop references measure: a rendering that
// changes as much as the mesh in total, but evenly, scores 4 against a mesh
// whose change comes in one step of four.
TEST(ImageMetricsTest, PopPenalisesAnEvenChangeAgainstASpikyMesh) {
  const std::vector<double> spiky = {0.0, 0.0, 0.0, 0.04};
  const std::vector<double> even = {0.01, 0.01, 0.01, 0.01};
  EXPECT_DOUBLE_EQ(PopRatio(even, spiky), 4.0);
  EXPECT_DOUBLE_EQ(PopRatio(spiky, spiky), 1.0);
}

TEST(ImageMetricsTest, PsnrFromMseIsCapped) {
  EXPECT_DOUBLE_EQ(PsnrFromMse(0.0), kMaxPsnrDb);
  EXPECT_DOUBLE_EQ(PsnrFromMse(1e-20), kMaxPsnrDb);
  EXPECT_NEAR(PsnrFromMse(0.01), 20.0, 1e-12);
}

}  // namespace
}  // namespace impostor

namespace impostor {
namespace {

// Shared-silhouette colour figures see colour only: a silhouette miss of the
// right colour costs the union PSNR a lot and the shared PSNR nothing.
TEST(SharedMetrics, ColourFiguresIgnoreSilhouetteMisses) {
  const Image a = MakeImage(64, {10, 10, 50, 50}, 200, 100, 50);
  const Image b = MakeImage(64, {14, 10, 50, 50}, 200, 100, 50);  // 4 columns short
  const ViewMetrics m = CompareViews(a.Pixels(), b.Pixels());
  EXPECT_LT(m.albedo_psnr_db, 25.0);
  EXPECT_EQ(m.albedo_psnr_shared_db, kMaxPsnrDb);
  EXPECT_NEAR(m.albedo_ssim_shared, 1.0, 1e-9);
  EXPECT_LT(m.albedo_ssim, 0.99);
}

// A uniform colour error of 10 levels over the shared pixels: PSNR
// -10 log10((10/255)^2) = 28.13 dB whatever the silhouettes do.
TEST(SharedMetrics, SharedPsnrHasTheClosedForm) {
  const Image a = MakeImage(64, {10, 10, 50, 50}, 200, 100, 50);
  const Image b = MakeImage(64, {20, 10, 60, 50}, 210, 110, 60);
  const double want = -10.0 * std::log10((10.0 / 255.0) * (10.0 / 255.0));
  EXPECT_NEAR(AlbedoPsnrSharedDb(a.Pixels(), b.Pixels()), want, 1e-9);
  // No overlap at all: nothing shared, the worst answer.
  const Image c = MakeImage(64, {0, 0, 8, 8}, 200, 100, 50);
  const Image d = MakeImage(64, {30, 30, 40, 40}, 200, 100, 50);
  EXPECT_EQ(AlbedoPsnrSharedDb(c.Pixels(), d.Pixels()), 0.0);
  EXPECT_EQ(AlbedoSsimShared(c.Pixels(), d.Pixels()), 0.0);
  // Nothing covered on either side: nothing to compare.
  const Image e = MakeImage(64, {0, 0, 0, 0}, 0, 0, 0);
  EXPECT_EQ(AlbedoPsnrSharedDb(e.Pixels(), e.Pixels()), kMaxPsnrDb);
}

// Shared SSIM is 1 for the same texture and drops when the texture moves.
TEST(SharedMetrics, SharedSsimSeesStructure) {
  const Image a = MakeChecker(64, {8, 8, 56, 56});
  const Image b = MakeChecker(64, {12, 8, 56, 56});
  EXPECT_NEAR(AlbedoSsimShared(a.Pixels(), b.Pixels()), 1.0, 1e-9);
  Image shifted = MakeChecker(64, {8, 8, 56, 56});
  for (int y = 8; y < 56; ++y) {
    for (int x = 8; x < 56; ++x) {
      const size_t i = (static_cast<size_t>(y) * 64 + x) * 4;
      const uint8_t v = (((x + 4) / 4 + y / 4) % 2) ? 200 : 60;  // the checker moved by a cell
      shifted.albedo[i] = v, shifted.albedo[i + 1] = v / 2, shifted.albedo[i + 2] = 255 - v;
    }
  }
  EXPECT_LT(AlbedoSsimShared(a.Pixels(), shifted.Pixels()), 0.0);
}

// Boundary error: two squares, one 3 pixels wider on the right: the moved
// edge's pixels are 3 away, the others 0, and the max is 3.
TEST(SharedMetrics, BoundaryErrorInPixels) {
  const Image a = MakeImage(64, {10, 10, 40, 40}, 200, 100, 50);
  const Image b = MakeImage(64, {10, 10, 43, 40}, 200, 100, 50);
  const BoundaryError same = SilhouetteBoundaryError(a.Pixels(), a.Pixels());
  EXPECT_EQ(same.mean_px, 0.0);
  EXPECT_EQ(same.max_px, 0.0);
  const BoundaryError e = SilhouetteBoundaryError(a.Pixels(), b.Pixels());
  EXPECT_NEAR(e.max_px, 3.0, 1e-9);
  EXPECT_GT(e.mean_px, 0.2);
  EXPECT_LT(e.mean_px, 1.0);
  // Symmetric.
  const BoundaryError r = SilhouetteBoundaryError(b.Pixels(), a.Pixels());
  EXPECT_NEAR(r.mean_px, e.mean_px, 1e-12);
  // Only one side covers: the image diagonal.
  const Image none = MakeImage(64, {0, 0, 0, 0}, 0, 0, 0);
  EXPECT_NEAR(SilhouetteBoundaryError(a.Pixels(), none.Pixels()).mean_px, std::hypot(64.0, 64.0), 1e-9);
  EXPECT_EQ(SilhouetteBoundaryError(none.Pixels(), none.Pixels()).max_px, 0.0);
}

}  // namespace
}  // namespace impostor
