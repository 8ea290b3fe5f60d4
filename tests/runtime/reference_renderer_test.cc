// The CPU reference renderer against a synthetic atlas ray-cast on the CPU:
// it reproduces every baked frame from that frame's own camera, encodes empty
// pixels like the bake, and between frames stays close to the true object.
#include "common/runtime/reference_renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <limits>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "tests/runtime/image_compare.h"
#include "tests/runtime/synthetic_atlas.h"

namespace impostor {
namespace {

using ::impostor::testing::BakeSyntheticAtlas;
using ::impostor::testing::Compare;
using ::impostor::testing::Comparison;
using ::impostor::testing::ExtractTile;
using ::impostor::testing::RenderSyntheticView;

struct Case {
  ViewLayout layout;
  int resolution;
};

std::string CaseName(const ::testing::TestParamInfo<Case>& info) {
  const ViewLayout& l = info.param.layout;
  std::string name = std::string(LayoutName(l.kind)) + "_" +
                     std::to_string(l.kind == LayoutKind::kRingTop ? l.ring_views : l.frames) + "_" +
                     std::to_string(info.param.resolution);
  for (char& c : name) {
    if (c == '-') c = '_';
  }
  return name;
}

class ReproducesBakedFrames : public ::testing::TestWithParam<Case> {};

TEST_P(ReproducesBakedFrames, AtEveryFrameDirection) {
  const Case c = GetParam();
  const ImpostorAtlas atlas = BakeSyntheticAtlas(c.layout, c.resolution);
  ASSERT_EQ(atlas.cameras.size(), static_cast<size_t>(FrameCount(c.layout)));
  const int tile = TileSize(c.resolution, GridSide(c.layout));
  double worst_iou = 1.0, worst_psnr = std::numeric_limits<double>::infinity();  // inf = identical
  for (const FrameCamera& frame : atlas.cameras) {
    // Duplicates on the fold are reproduced by their canonical twin.
    const int canonical = CanonicalFrameIndex(c.layout, frame.index);
    const ViewImages baked = ExtractTile(atlas, canonical);
    for (BlendMode mode : {BlendMode::kTriangle3, BlendMode::kBilinear4}) {
      for (int variant = 0; variant < 3; ++variant) {  // plain flat, plain parallax, depth
        const ReferenceRenderOptions options{mode, variant == 1,
                                             variant == 2 ? Reconstruction::kDepth : Reconstruction::kPlain};
        const FrameCamera view = ViewCameraFor(atlas.cameras[canonical].direction);
        const ViewImages got = RenderImpostorView(atlas, view, tile, options);
        ASSERT_EQ(got.width, tile);
        const Comparison cmp = Compare(got, baked);
        worst_iou = std::min(worst_iou, cmp.iou);
        worst_psnr = std::min(worst_psnr, cmp.albedo_psnr_db);
        EXPECT_EQ(cmp.coverage_mismatch, 0) << "frame " << frame.index << " variant " << variant;
        EXPECT_LE(cmp.albedo_max_diff, 1) << "frame " << frame.index << " variant " << variant;
        EXPECT_LE(cmp.orm_max_diff, 1) << "frame " << frame.index;
        EXPECT_LE(cmp.normal_max_diff, 8) << "frame " << frame.index;  // renormalisation of 16-bit normals
        EXPECT_LE(cmp.depth_max_diff, 4) << "frame " << frame.index;
      }
    }
  }
  std::printf("[ figures  ] %s frames=%d tile=%d: worst IoU %.6f, worst albedo PSNR %.2f dB\n",
              CaseName(::testing::TestParamInfo<Case>(c, 0)).c_str(), FrameCount(c.layout), tile, worst_iou,
              worst_psnr);
  EXPECT_EQ(worst_iou, 1.0);
  EXPECT_GE(worst_psnr, 60.0);
}

INSTANTIATE_TEST_SUITE_P(
    Synthetic, ReproducesBakedFrames,
    ::testing::Values(Case{{LayoutKind::kOctahedral, 4, 0}, 256}, Case{{LayoutKind::kOctahedral, 6, 0}, 384},
                      Case{{LayoutKind::kHemiOctahedral, 5, 0}, 320},
                      Case{{LayoutKind::kHemiOctahedral, 8, 0}, 384},
                      Case{{LayoutKind::kAzimuthElevation, 3, 0}, 192},
                      Case{{LayoutKind::kAzimuthElevation, 7, 0}, 448},
                      Case{{LayoutKind::kRingTop, 3, 5}, 192},   // 6 frames in a 3 x 3 grid
                      Case{{LayoutKind::kRingTop, 5, 24}, 320},  // 25 frames, 5 x 5
                      Case{{LayoutKind::kBillboard, 3, 8}, 192}),
    CaseName);

// Held-out views of the other layouts on the synthetic object (64 px
// views). Measured when written (min IoU / min albedo PSNR, both blends):
// azimuth-elevation 11 x 11: 0.952 / 16.7 dB flat, 0.967 / 19.3 dB with
// parallax; ring-top 24: 0.767 / 9.5 dB flat, 0.976 / 19.0 dB parallax;
// billboard: 0.740 / 8.9 dB flat, 0.973 / 17.7 dB parallax. The ring layouts
// need parallax: their frames are 15 and 45 degrees apart in azimuth and up
// to 90 in elevation.
TEST(ReferenceRenderer, NewLayoutsBetweenFramesStayCloseToTheObject) {
  struct Held {
    ViewLayout layout;
    int resolution;
    double min_iou_parallax;
  };
  // Ring layouts are meant for views near the horizon: there they are held
  // to a floor; azimuth-elevation over the whole sphere.
  const std::vector<Held> cases = {{{LayoutKind::kAzimuthElevation, 11, 0}, 704, 0.95},
                                   {{LayoutKind::kRingTop, 5, 24}, 320, 0.9},
                                   {{LayoutKind::kBillboard, 3, 8}, 192, 0.8}};
  const std::vector<glm::vec3> sphere_views = {
      glm::normalize(glm::vec3(0.31f, 0.42f, 0.77f)), glm::normalize(glm::vec3(-0.6f, 0.1f, 0.3f)),
      glm::normalize(glm::vec3(0.2f, -0.7f, -0.4f)), glm::normalize(glm::vec3(0.05f, 0.99f, 0.02f))};
  const std::vector<glm::vec3> horizon_views = {
      glm::normalize(glm::vec3(0.31f, 0.12f, 0.77f)), glm::normalize(glm::vec3(-0.6f, 0.05f, 0.3f)),
      glm::normalize(glm::vec3(0.2f, 0.3f, -0.4f)), glm::normalize(glm::vec3(-0.5f, 0.4f, -0.6f))};
  for (const Held& h : cases) {
    const ImpostorAtlas atlas = BakeSyntheticAtlas(h.layout, h.resolution);
    const auto& views = h.layout.kind == LayoutKind::kAzimuthElevation ? sphere_views : horizon_views;
    for (BlendMode mode : {BlendMode::kTriangle3, BlendMode::kBilinear4}) {
      for (bool parallax : {false, true}) {
        double min_iou = 1.0, min_psnr = 1e9;
        for (const glm::vec3& d : views) {
          const FrameCamera view = ViewCameraFor(d);
          const Comparison cmp = Compare(RenderImpostorView(atlas, view, 64, {mode, parallax}),
                                         RenderSyntheticView(view, 64));
          min_iou = std::min(min_iou, cmp.iou);
          min_psnr = std::min(min_psnr, cmp.albedo_psnr_db);
        }
        std::printf("[ figures  ] held-out %s %s parallax=%d: min IoU %.4f, min albedo PSNR %.2f dB\n",
                    CaseName(::testing::TestParamInfo<Case>(Case{h.layout, h.resolution}, 0)).c_str(),
                    std::string(BlendModeName(mode)).c_str(), parallax, min_iou, min_psnr);
        if (parallax) EXPECT_GE(min_iou, h.min_iou_parallax);
        else EXPECT_GE(min_iou, 0.7);
      }
    }
  }
}

TEST(ReferenceRenderer, EmptyPixelsUseTheBakeEncodings) {
  const ImpostorAtlas atlas = BakeSyntheticAtlas(LayoutKind::kOctahedral, 4, 128);
  const ViewImages v = RenderImpostorView(atlas, ViewCameraFor(glm::normalize(glm::vec3(0.3f, 0.5f, 0.8f))), 64, {});
  // The corner pixel lies outside the bounding sphere's disc: always empty.
  EXPECT_EQ(v.albedo_alpha[0], 0);
  EXPECT_EQ(v.albedo_alpha[3], 0);
  EXPECT_EQ(v.normal_depth[0], 32768);
  EXPECT_EQ(v.normal_depth[1], 32768);
  EXPECT_EQ(v.normal_depth[2], 32768);
  EXPECT_EQ(v.normal_depth[3], 65535);
  EXPECT_EQ(v.orm[3], 0);
  // Coverage is binary.
  for (size_t i = 3; i < v.albedo_alpha.size(); i += 4) {
    ASSERT_TRUE(v.albedo_alpha[i] == 0 || v.albedo_alpha[i] == 255);
  }
}

TEST(ReferenceRenderer, RejectsInconsistentAtlases) {
  ImpostorAtlas atlas = BakeSyntheticAtlas(LayoutKind::kOctahedral, 4, 128);
  const FrameCamera view = ViewCameraFor({0, 1, 0});
  EXPECT_EQ(RenderImpostorView(atlas, view, 0, {}).width, 0);
  ImpostorAtlas short_maps = atlas;
  short_maps.normal_depth.resize(10);
  EXPECT_EQ(RenderImpostorView(short_maps, view, 32, {}).width, 0);
  ImpostorAtlas no_cameras = atlas;
  no_cameras.cameras.clear();
  EXPECT_EQ(RenderImpostorView(no_cameras, view, 32, {}).width, 0);
  ImpostorAtlas no_orm = atlas;
  no_orm.orm.clear();
  const ViewImages v = RenderImpostorView(no_orm, view, 32, {});
  EXPECT_EQ(v.width, 32);
  EXPECT_TRUE(v.orm.empty());
}

// Held-out views between frames (12 x 12 octahedral, 64 px tiles and views):
// the impostor is an approximation, but a faithful one, and marching the
// captured depth (parallax) makes silhouettes follow the view. Measured when
// written: IoU >= 0.942 / PSNR >= 16.5 dB without parallax, IoU >= 0.985 /
// PSNR >= 21.9 dB with it (PSNR over the union of both silhouettes, so it is
// dominated by the silhouette pixels that differ).
TEST(ReferenceRenderer, BetweenFramesStaysCloseToTheObject) {
  const ImpostorAtlas atlas = BakeSyntheticAtlas(LayoutKind::kOctahedral, 12, 768);
  const std::vector<glm::vec3> views = {
      glm::normalize(glm::vec3(0.31f, 0.42f, 0.77f)), glm::normalize(glm::vec3(-0.6f, 0.1f, 0.3f)),
      glm::normalize(glm::vec3(0.2f, -0.7f, -0.4f)), glm::normalize(glm::vec3(0.05f, 0.99f, 0.02f))};
  for (BlendMode mode : {BlendMode::kTriangle3, BlendMode::kBilinear4}) {
    double flat_iou = 0.0;
    for (bool parallax : {false, true}) {
      double min_iou = 1.0, min_psnr = 1e9;
      for (const glm::vec3& d : views) {
        const FrameCamera view = ViewCameraFor(d);
        const Comparison cmp = Compare(RenderImpostorView(atlas, view, 64, {mode, parallax}),
                                       RenderSyntheticView(view, 64));
        min_iou = std::min(min_iou, cmp.iou);
        min_psnr = std::min(min_psnr, cmp.albedo_psnr_db);
      }
      std::printf("[ figures  ] held-out %s parallax=%d: min IoU %.4f, min albedo PSNR %.2f dB\n",
                  std::string(BlendModeName(mode)).c_str(), parallax, min_iou, min_psnr);
      EXPECT_GE(min_iou, parallax ? 0.98 : 0.93);
      EXPECT_GE(min_psnr, parallax ? 20.0 : 15.0);
      if (parallax) {
        EXPECT_GT(min_iou, flat_iou) << "parallax must sharpen the silhouette";
      }
      flat_iou = min_iou;
    }
  }
}

}  // namespace
}  // namespace impostor

namespace impostor {
namespace {

// Depth of covered pixels in both images (16-bit levels), over pixels whose
// 3 x 3 neighbourhood is covered in the truth with no depth step larger than
// a pixel (away from silhouettes and occlusion edges, where no reconstruction
// can be judged per pixel).
struct DepthError {
  int interior = 0;        // pixels judged
  int beyond_a_pixel = 0;  // of those, depth off by more than one pixel
  double mean_pixels = 0;  // mean error in pixels
};

DepthError InteriorDepthError(const ViewImages& got, const ViewImages& truth) {
  DepthError e;
  const int n = truth.width;
  const double pixel = 65535.0 / n;  // one pixel of the view in depth levels (2 r across)
  double sum = 0.0;
  for (int y = 1; y + 1 < n; ++y) {
    for (int x = 1; x + 1 < n; ++x) {
      const size_t i = static_cast<size_t>(y) * n + x;
      bool interior = got.albedo_alpha[i * 4 + 3] == 255;
      for (int dy = -1; dy <= 1 && interior; ++dy) {
        for (int dx = -1; dx <= 1 && interior; ++dx) {
          const size_t j = static_cast<size_t>(y + dy) * n + (x + dx);
          interior = truth.albedo_alpha[j * 4 + 3] == 255 &&
                     std::abs(truth.normal_depth[j * 4 + 3] - truth.normal_depth[i * 4 + 3]) <= pixel;
        }
      }
      if (!interior) continue;
      const double err = std::abs(got.normal_depth[i * 4 + 3] - truth.normal_depth[i * 4 + 3]) / pixel;
      ++e.interior;
      sum += err;
      if (err > 1.0) ++e.beyond_a_pixel;
    }
  }
  e.mean_pixels = e.interior ? sum / e.interior : 0.0;
  return e;
}

// Between two frames of a scene with known geometry (two balls, one partly
// hiding the other), depth mode puts every pixel's surface within a pixel of
// the true surface and samples the same point in both frames, so its colour
// is closer to the truth than plain's double image and parallax's blend.
TEST(DepthReconstruction, BetweenTwoFramesFindsTheSurfaceWithinAPixel) {
  // Octahedral 6 x 6: frames 36 degrees apart; tiles of 128 px, views of 128.
  const ImpostorAtlas atlas = BakeSyntheticAtlas(LayoutKind::kOctahedral, 6, 768);
  const ViewLayout layout{LayoutKind::kOctahedral, 6, 0};
  int compared = 0;
  for (const auto& [a, b] : std::vector<std::pair<int, int>>{{14, 15}, {14, 20}, {8, 9}, {21, 27}}) {
    const glm::vec3 d = glm::normalize(FrameDirectionAt(layout, a) + FrameDirectionAt(layout, b));
    const FrameCamera view = ViewCameraFor(d);
    const FrameBlend blend = BlendFrames(layout, d, BlendMode::kTriangle3);
    int weighted = 0;
    for (int k = 0; k < blend.count; ++k) weighted += blend.entries[k].weight > 1e-3f;
    ASSERT_GE(weighted, 2) << "the view must lie between frames";
    const ViewImages truth = RenderSyntheticView(view, 128);
    const ViewImages depth = RenderImpostorView(atlas, view, 128, {BlendMode::kTriangle3, false, Reconstruction::kDepth});
    const ViewImages plain = RenderImpostorView(atlas, view, 128, {BlendMode::kTriangle3, false});
    const ViewImages parallax = RenderImpostorView(atlas, view, 128, {BlendMode::kTriangle3, true});
    const DepthError de = InteriorDepthError(depth, truth);
    const DepthError pe = InteriorDepthError(plain, truth);
    const Comparison dc = Compare(depth, truth), pc = Compare(plain, truth), xc = Compare(parallax, truth);
    std::printf("[ figures  ] frames %d|%d: depth mode: %d interior pixels, %d beyond a pixel, mean %.3f px, IoU %.4f, "
                "shared albedo PSNR %.2f dB; plain: mean %.3f px, IoU %.4f, %.2f dB; parallax: IoU %.4f, %.2f dB\n",
                a, b, de.interior, de.beyond_a_pixel, de.mean_pixels, dc.iou, dc.albedo_psnr_shared_db,
                pe.mean_pixels, pc.iou, pc.albedo_psnr_shared_db, xc.iou, xc.albedo_psnr_shared_db);
    ASSERT_GT(de.interior, 2000);
    EXPECT_EQ(de.beyond_a_pixel, 0);
    EXPECT_LT(de.mean_pixels, 0.25);
    EXPECT_GT(dc.albedo_psnr_shared_db, pc.albedo_psnr_shared_db + 3.0);
    EXPECT_GE(dc.albedo_psnr_shared_db, xc.albedo_psnr_shared_db);
    EXPECT_GE(dc.iou, pc.iou);
    ++compared;
  }
  EXPECT_EQ(compared, 4);
}

TEST(DepthReconstruction, ModeNamesRoundTripAndBadNamesAreRefused) {
  for (Reconstruction m : {Reconstruction::kPlain, Reconstruction::kDepth}) {
    auto parsed = ParseReconstruction(ReconstructionName(m));
    ASSERT_TRUE(parsed.ok());
    EXPECT_EQ(*parsed, m);
  }
  const auto bad = ParseReconstruction("relief");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("reconstruction"), std::string_view::npos);
  EXPECT_NE(bad.status().message().find("relief"), std::string_view::npos);
  EXPECT_FALSE(ParseReconstruction("").ok());
  EXPECT_FALSE(ParseReconstruction("Depth").ok());
}

TEST(DepthReconstruction, AgreementFallsToZeroBeyondTheTolerance) {
  EXPECT_EQ(DepthAgreement(0.3f, 0.3f), 1.0f);
  EXPECT_EQ(DepthAgreement(0.3f, 0.3f + 0.4f * kDepthAgreement), 1.0f);
  EXPECT_NEAR(DepthAgreement(0.3f, 0.3f - 0.75f * kDepthAgreement), 0.5f, 1e-4f);
  EXPECT_EQ(DepthAgreement(0.3f, 0.3f + kDepthAgreement), 0.0f);
  EXPECT_EQ(DepthAgreement(-0.9f, 0.9f), 0.0f);
}

// A march hit deep behind the surface its frame saw lies in that frame's
// extrusion (its silhouette pushed backwards): it counts only as far as the
// other blended frames see the point inside their silhouettes.
TEST(DepthReconstruction, AHitDeepInItsFramesExtrusionNeedsTheOtherFrames) {
  const FrameCamera front = CameraForDirection({0.0f, 0.0f, 1.0f});
  const FrameCamera side = CameraForDirection(glm::normalize(glm::vec3(0.5f, 0.0f, 1.0f)));
  const glm::vec3 origin(0.1f, 0.2f, 5.0f);
  const glm::vec3 ray_unit(0.0f, 0.0f, -1.0f);
  const PlaneSample front_hit{true, {0.1f, 0.2f}, -0.3f};  // where the front frame's march stopped
  struct Case {
    float behind;       // how far the hit lies behind the surface the front frame saw
    float side_weight;  // the side frame's blend weight (the front frame has the rest)
    float side_alpha;   // the side frame's coverage wherever it is sampled
    float coverage;     // the pixel's: the front frame's weight times its confirmation
  };
  const std::vector<Case> cases = {
      {0.3f, 0.2f, 0.0f, 0.0f},                          // deep, the side frame sees empty space
      {0.3f, 0.2f, 1.0f, 0.8f},                          // deep, the side frame sees the object there
      {0.3f, 0.2f, 0.5f, 0.0f},                          // deep, seen inside by half: not yet
      {0.3f, 0.2f, 0.6f, 0.8f * 0.4f},                   // deep, seen inside by 0.6: 0.4 of it, not covered
      {0.3f, 0.2f, 0.7f, 0.8f * 0.8f},                   // deep, seen inside by 0.7: 0.8 of it, covered
      {0.3f, 0.2f, 0.9f, 0.8f},                          // deep, seen inside by 0.9: all of it
      {0.3f, 0.0f, 0.0f, 1.0f},                          // deep, but no other frame is blended
      {0.5f * kExtrusionDepth, 0.2f, 0.0f, 0.8f},        // near the surface: no confirmation needed
      {1.5f * kExtrusionDepth, 0.2f, 0.0f, 0.0f},        // just beyond the extrusion depth
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(::testing::Message() << "behind " << c.behind << " side weight " << c.side_weight
                                      << " side alpha " << c.side_alpha);
    const std::array<DepthEntry, 4> entries = {DepthEntry{&front, 1.0f - c.side_weight},
                                               DepthEntry{&side, c.side_weight}};
    const DepthMarch march = [&](int entry) { return entry == 0 ? front_hit : PlaneSample{}; };
    const DepthSurface surface = [&](int entry, glm::vec2, float* height) {
      *height = front_hit.height + c.behind;
      return entry == 0 ? 1.0f : c.side_alpha;
    };
    const DepthPixel pixel = ReconstructDepth(entries, 2, origin, ray_unit, march, surface);
    EXPECT_NEAR(pixel.coverage, c.coverage, 1e-6f);
    EXPECT_EQ(pixel.samples[0].used, c.coverage >= 0.5f);
  }
}

// The agreement test's votes as they were written before the reads were
// batched (each candidate against every frame, each read on its own, the
// frame's own hit read again): the oracle for the batched form.
DepthPixel VotesOneReadAtATime(const std::array<DepthEntry, 4>& entries, int count, glm::vec3 origin,
                               glm::vec3 ray_unit, const DepthMarch& march, const DepthSurface& surface) {
  DepthPixel out;
  std::array<PlaneSample, 4> hits;
  std::array<float, 4> hit_alpha{}, lambda{};
  for (int i = 0; i < count; ++i) {
    if (!(entries[i].weight > 0.0f)) continue;
    hits[i] = march(i);
    if (!hits[i].valid) continue;
    float height = 0.0f;
    hit_alpha[i] = surface(i, hits[i].st, &height);
    if (!(hit_alpha[i] > 0.0f)) {
      hits[i].valid = false;
      continue;
    }
    const glm::vec3 point = FramePoint(*entries[i].frame, hits[i]);
    const float confirmed =
        height - hits[i].height > kExtrusionDepth
            ? ExtrusionConfirmation(depth_internal::OthersInsideShare(entries, count, i, point, surface))
            : 1.0f;
    if (!(confirmed > 0.0f)) {
      hits[i].valid = false;
      continue;
    }
    out.coverage += entries[i].weight * hit_alpha[i] * confirmed;
    lambda[i] = RayDistance(origin, ray_unit, point);
  }
  if (out.coverage < 0.5f) return out;
  std::array<std::array<DepthSampleAt, 4>, 4> votes;
  std::array<float, 4> support{};
  float most = 0.0f;
  for (int c = 0; c < count; ++c) {
    if (!hits[c].valid) continue;
    const glm::vec3 point = FramePoint(*entries[c].frame, hits[c]);
    for (int j = 0; j < count; ++j) {
      if (!(entries[j].weight > 0.0f)) continue;
      const PlaneSample at = j == c ? hits[j] : ProjectPointToFrame(*entries[j].frame, point);
      float height = 0.0f;
      const float alpha = surface(j, at.st, &height);
      DepthSampleAt& v = votes[c][j];
      v.st = at.st;
      if (!(alpha > 0.0f)) continue;
      v.weight = entries[j].weight * alpha * DepthAgreement(height, at.height);
      v.used = v.weight > 0.0f;
      support[c] += v.weight;
    }
    most = std::max(most, support[c]);
  }
  int best = -1;
  for (int c = 0; c < count; ++c) {
    if (!hits[c].valid || !(support[c] >= kSupportShare * most)) continue;
    if (best < 0 || lambda[c] > lambda[best]) best = c;
  }
  if (best >= 0 && support[best] > 0.0f) {
    out.samples = votes[best];
    return out;
  }
  for (int j = 0; j < count; ++j) {
    if (hits[j].valid) out.samples[j] = {true, hits[j].st, entries[j].weight * hit_alpha[j]};
  }
  return out;
}

// ReconstructDepth and ReconstructDepthBatched (its reads of each frame
// taken together, the frame's own hit read once) give what the oracle
// above gives, to the bit, over random frames, weights, march hits and a
// surface of bumps and holes.
TEST(DepthReconstruction, BatchedReadsVoteAsOneAtATime) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f), weight(0.0f, 1.0f);
  int covered = 0, dropped = 0;
  for (int r = 0; r < 20000; ++r) {
    const glm::vec3 d = glm::normalize(glm::vec3(unit(rng), unit(rng), unit(rng)));
    std::array<FrameCamera, 4> frames;
    std::array<DepthEntry, 4> entries;
    const int count = 2 + r % 3;
    for (int i = 0; i < count; ++i) {
      frames[i] = CameraForDirection(glm::normalize(d + 0.5f * glm::vec3(unit(rng), unit(rng), unit(rng))));
      entries[i] = {&frames[i], r % 7 == i ? 0.0f : weight(rng)};
    }
    std::array<PlaneSample, 4> hits;
    for (int i = 0; i < count; ++i) hits[i] = {weight(rng) < 0.8f, {0.3f * unit(rng), 0.3f * unit(rng)}, 0.5f * unit(rng)};
    const DepthMarch march = [&](int i) { return hits[i]; };
    const DepthSurface surface = [](int i, glm::vec2 st, float* height) {
      *height = 0.4f * std::sin(6.0f * st.x + static_cast<float>(i)) * std::cos(4.0f * st.y);
      return std::clamp(1.5f - 4.0f * (st.x * st.x + st.y * st.y), 0.0f, 1.0f);
    };
    const glm::vec3 origin = 3.0f * d;
    const DepthPixel want = VotesOneReadAtATime(entries, count, origin, -d, march, surface);
    const DepthPixel plain = ReconstructDepth(entries, count, origin, -d, march, surface);
    const DepthPixel batched = ReconstructDepthBatched(
        entries, count, origin, -d, march, surface,
        [&](int i, int n, const glm::vec2* st, float* alpha, float* height) {
          for (int k = n - 1; k >= 0; --k) alpha[k] = surface(i, st[k], &height[k]);  // any order
        });
    for (const DepthPixel* got : {&plain, &batched}) {
      ASSERT_EQ(got->coverage, want.coverage) << "case " << r;
      for (int j = 0; j < 4; ++j) {
        ASSERT_EQ(got->samples[j].used, want.samples[j].used) << "case " << r << " frame " << j;
        ASSERT_EQ(got->samples[j].st, want.samples[j].st) << "case " << r << " frame " << j;
        ASSERT_EQ(got->samples[j].weight, want.samples[j].weight) << "case " << r << " frame " << j;
      }
    }
    if (want.coverage >= 0.5f) ++covered;
    for (int j = 0; j < count; ++j) dropped += want.coverage >= 0.5f && entries[j].weight > 0.0f && !want.samples[j].used;
  }
  EXPECT_GT(covered, 2000);
  EXPECT_GT(dropped, 500) << "frames must drop out of some pixels";
}

TEST(DepthReconstruction, ExtrusionConfirmationRampsOverTheOtherFramesShare) {
  EXPECT_EQ(ExtrusionConfirmation(0.0f), 0.0f);
  EXPECT_EQ(ExtrusionConfirmation(0.5f), 0.0f);
  EXPECT_FLOAT_EQ(ExtrusionConfirmation(0.625f), 0.5f);
  EXPECT_EQ(ExtrusionConfirmation(kExtrusionConfirm), 1.0f);
  EXPECT_EQ(ExtrusionConfirmation(1.0f), 1.0f);
  EXPECT_LT(ExtrusionConfirmation(0.6f), ExtrusionConfirmation(0.7f));
}

}  // namespace
}  // namespace impostor
