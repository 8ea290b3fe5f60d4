// Virtual-plane projection: identity for a frame's own camera, exact for
// points on the plane, and parallax that finds a surface at a known height.
#include "common/runtime/virtual_plane.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <random>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "common/runtime/reference_renderer.h"

namespace impostor {
namespace {

// The coarse steps' heights, to tell a crossing's finer reads from them.
const std::array<float, kParallaxSteps + 1> kCoarse = [] {
  std::array<float, kParallaxSteps + 1> h{};
  for (int i = 0; i <= kParallaxSteps; ++i) h[i] = CoarseStepHeight(i);
  return h;
}();

TEST(VirtualPlane, FrameCameraSeesItsOwnTileUnchanged) {
  for (const FrameCamera& frame : AtlasCameras(LayoutKind::kOctahedral, 6, 384)) {
    const FrameCamera view = ViewCameraFor(frame.direction);
    for (glm::vec2 st : {glm::vec2(0.0f), glm::vec2(-0.9f, 0.3f), glm::vec2(0.99f, -0.99f)}) {
      const PlaneSample p = ProjectToFrame(view, frame, st);
      ASSERT_TRUE(p.valid);
      EXPECT_NEAR(p.st.x, st.x, 1e-5f);
      EXPECT_NEAR(p.st.y, st.y, 1e-5f);
    }
  }
}

// A point q on frame f's plane seen by another view must land where f's
// camera put it: (dot(q, right_f), dot(q, up_f)).
TEST(VirtualPlane, PointsOnThePlaneProjectWhereTheFrameCameraSawThem) {
  const std::vector<FrameCamera> frames = AtlasCameras(LayoutKind::kHemiOctahedral, 8, 512);
  const FrameCamera& frame = frames[FrameIndex(8, {3, 4})];
  const FrameCamera view = ViewCameraFor(glm::normalize(frame.direction + glm::vec3(0.2f, 0.05f, -0.1f)));
  for (glm::vec2 fst : {glm::vec2(0.1f, 0.2f), glm::vec2(-0.5f, 0.4f), glm::vec2(0.7f, -0.6f)}) {
    const glm::vec3 q = fst.x * frame.right + fst.y * frame.up;  // on the plane
    const glm::vec2 view_st(glm::dot(q, view.right), glm::dot(q, view.up));
    const PlaneSample p = ProjectToFrame(view, frame, view_st);
    ASSERT_TRUE(p.valid);
    EXPECT_NEAR(p.st.x, fst.x, 1e-5f);
    EXPECT_NEAR(p.st.y, fst.y, 1e-5f);
  }
}

// A flat surface at height h above the plane: the march must find where the
// view ray meets it, to within its bisection step (2 / 16 / 2^4 in height).
TEST(VirtualPlane, ParallaxFindsASurfaceAtItsHeight) {
  const FrameCamera frame = CameraForDirection(glm::normalize(glm::vec3(0.3f, 0.8f, 0.2f)));
  const FrameCamera view = CameraForDirection(glm::normalize(frame.direction + glm::vec3(0.25f, -0.1f, 0.1f)));
  const float h = 0.4f;
  const glm::vec2 view_st(0.2f, -0.1f);
  const PlaneSample flat = ProjectToFrame(view, frame, view_st);
  const PlaneSample refined = ProjectToFrameParallax(view, frame, view_st, [&](glm::vec2, float* height) {
    *height = h;
    return true;
  });
  const PlaneSample truth = ProjectToFrame(view, frame, view_st, h);
  ASSERT_TRUE(refined.valid);
  const float tan_angle = std::tan(std::acos(glm::dot(view.direction, frame.direction)));
  const float tolerance = 2.0f / kParallaxSteps / (1 << kParallaxRefinements) * tan_angle + 1e-5f;
  EXPECT_NEAR(refined.st.x, truth.st.x, tolerance);
  EXPECT_NEAR(refined.st.y, truth.st.y, tolerance);
  EXPECT_GT(glm::distance(flat.st, truth.st), 0.05f) << "the case must have visible parallax";
  // A ray that meets no surface samples nothing.
  EXPECT_FALSE(ProjectToFrameParallax(view, frame, view_st, [](glm::vec2, float*) { return false; }).valid);
  // A surface only right of s = 0.3 in the frame: the ray enters it there
  // only if it gets that far; the sample is always on covered ground.
  const PlaneSample partial = ProjectToFrameParallax(view, frame, view_st, [](glm::vec2 st, float* height) {
    *height = 0.9f;
    return st.x > 0.3f;
  });
  if (partial.valid) {
    EXPECT_GT(partial.st.x, 0.3f);
  }
}

// A ray that crosses the frame's silhouette between two march steps can
// pass through a sliver of the solid thinner than a step (a grazing edge).
// Here the ray leaves empty ground between steps 7 and 8 and meets a wall
// (surface height 1) that ends before step 8, where the covered ground lies
// well below the ray: the coarse march misses it, the finer sampling of
// the crossing interval (depth mode's) finds it, on the wall.
TEST(VirtualPlane, SilhouetteCrossingsAreSampledFinerWhenAsked) {
  const FrameCamera frame = CameraForDirection(glm::normalize(glm::vec3(0.3f, 0.8f, 0.2f)));
  const FrameCamera view = CameraForDirection(glm::normalize(frame.direction + glm::vec3(0.25f, -0.1f, 0.1f)));
  const glm::vec2 view_st(0.2f, -0.1f);
  const glm::vec3 origin = ViewRayOrigin(view, view_st);
  const FramePlaneRay plane(frame, origin, -view.direction);
  const auto height_at_step = [](int i) { return 1.0f - 2.0f * static_cast<float>(i) / kParallaxSteps; };
  const float s7 = plane.At(height_at_step(7)).st.x, s8 = plane.At(height_at_step(8)).st.x;
  const float step = s8 - s7;
  ASSERT_GT(std::abs(step), 1e-3f);
  // u: how far along the step, 0 at step 7 and 1 at step 8.
  const auto u = [&](glm::vec2 st) { return (st.x - s7) / step; };
  // The ray's height where its projection is at u (linear in u).
  const auto ray_height = [&](float at) { return height_at_step(7) + at * (height_at_step(8) - height_at_step(7)); };
  const auto reader = [&](glm::vec2 st, float* height) {
    const float at = u(st);
    if (at < 0.3f) return false;                  // empty before the edge
    *height = at <= 0.8f ? 1.0f : ray_height(at) - 0.5f;  // the wall, then ground far below the ray
    return true;
  };
  EXPECT_FALSE(IntersectFrameHeightField(frame, origin, -view.direction, reader).valid)
      << "the case must fall between two coarse steps";
  const PlaneSample fine = IntersectFrameHeightField(frame, origin, -view.direction, reader, /*refine_crossings=*/true);
  ASSERT_TRUE(fine.valid);
  EXPECT_GE(u(fine.st), 0.3f);
  EXPECT_LE(u(fine.st), 0.8f);
}

// MarchFrameHeightField with a reader that takes up to 2, 3, 4 or 8
// heights a call (as the reference renderer's SIMD reader takes 4) finds
// what the one-at-a-time march finds, to the bit, with and without the finer
// sampling of silhouette crossings: over random rays through a height field
// of bumps and holes, so that coarse hits, crossings found and missed, and
// misses all occur.
TEST(VirtualPlane, BatchedReadsMarchAsOneAtATime) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  const auto reader = [](glm::vec2 st, float* height) {
    const float bumps = 0.6f * std::sin(7.0f * st.x) * std::cos(5.0f * st.y);
    if (bumps < -0.25f || st.x * st.x + st.y * st.y > 0.8f) return false;  // holes and the outline
    *height = bumps;
    return true;
  };
  int hits = 0, misses = 0, fine_reads = 0, differs_when_refined = 0;
  for (int r = 0; r < 4000; ++r) {
    const glm::vec3 d = glm::normalize(glm::vec3(unit(rng), unit(rng), unit(rng)));
    const FrameCamera frame = CameraForDirection(d);
    const FrameCamera view = CameraForDirection(glm::normalize(d + 0.6f * glm::vec3(unit(rng), unit(rng), unit(rng))));
    const glm::vec3 origin = ViewRayOrigin(view, {unit(rng), unit(rng)});
    const FramePlaneRay plane(frame, origin, -view.direction);
    for (bool refine : {false, true}) {
      const PlaneSample want = IntersectFrameHeightField(frame, origin, -view.direction, reader, refine);
      (want.valid ? hits : misses) += 1;
      if (refine && want.valid != IntersectFrameHeightField(frame, origin, -view.direction, reader).valid) {
        ++differs_when_refined;
      }
      for (int width : {2, 3, 4, kMaxCoarseBatch}) {
        const auto batch = [&](const FramePlaneRay& p, const float* heights, int n, CoarseStep* steps) {
          const int m = std::min(n, width);
          for (int k = 0; k < m; ++k) {
            if (std::find(std::begin(kCoarse), std::end(kCoarse), heights[k]) == std::end(kCoarse)) ++fine_reads;
            steps[k].covered = reader(p.At(heights[k]).st, &steps[k].surface);
          }
          return m;
        };
        const PlaneSample got = MarchFrameHeightField(plane, reader, batch, refine);
        ASSERT_EQ(got.valid, want.valid) << "ray " << r << " width " << width << " refine " << refine;
        ASSERT_EQ(got.st, want.st) << "ray " << r << " width " << width << " refine " << refine;
        ASSERT_EQ(got.height, want.height) << "ray " << r << " width " << width << " refine " << refine;
      }
    }
  }
  EXPECT_GT(hits, 1000);
  EXPECT_GT(misses, 1000);
  EXPECT_GT(fine_reads, 1000) << "crossings must be sampled finer";
  EXPECT_GT(differs_when_refined, 10) << "the finer sampling must change some rays";
}

TEST(VirtualPlane, FramesFacingAwayAreInvalid) {
  const FrameCamera frame = CameraForDirection({0, 0, 1});
  EXPECT_FALSE(ProjectToFrame(CameraForDirection({0, 0, -1}), frame, {0, 0}).valid);
  EXPECT_FALSE(ProjectToFrame(CameraForDirection({1, 0, 0}), frame, {0, 0}).valid);
  EXPECT_TRUE(ProjectToFrame(CameraForDirection(glm::normalize(glm::vec3(1, 0, 0.1f))), frame, {0, 0}).valid);
}

TEST(VirtualPlane, TilePixelsFollowFrameCameraConventions) {
  const TileRect tile{64, 128, 64, 64};
  EXPECT_EQ(FrameStToPixel(tile, {-1, 1}), glm::vec2(64, 128));    // top-left corner
  EXPECT_EQ(FrameStToPixel(tile, {1, -1}), glm::vec2(128, 192));   // bottom-right
  EXPECT_EQ(FrameStToPixel(tile, {0, 0}), glm::vec2(96, 160));     // centre
}

}  // namespace
}  // namespace impostor
