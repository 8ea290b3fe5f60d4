// The quality pass on the layouts beyond the octahedral ones
// (azimuth-elevation, ring-top, billboard): it runs (the reference renderer
// draws every layout), its held-out views cover each layout's domain, and it
// measures a real bake of DamagedHelmet through the Vulkan renderer (Mesa
// lavapipe suffices).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "tests/gpu/shared_renderer_test.h"
#include "common/request/bake_request.h"
#include "common/atlas/frame_camera.h"
#include "common/request/layout_parameters.h"
#include "worker/bake/atlas_bake.h"
#include "worker/bake/quality_pass.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

const fs::path kHelmet = fs::path(IMPOSTOR_TEST_ASSETS_DIR) / "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb";
constexpr float kDegrees = 57.2957795f;

float ElevationDeg(glm::vec3 d) { return std::asin(std::clamp(d.y, -1.0f, 1.0f)) * kDegrees; }

TEST(LayoutsHeldOutViews, CoverEachLayoutsDomainAndAvoidBakedFrames) {
  const std::vector<ViewLayout> layouts = {{LayoutKind::kAzimuthElevation, 11, 0},
                                           {LayoutKind::kAzimuthElevation, 3, 0},
                                           {LayoutKind::kRingTop, 5, 24},
                                           {LayoutKind::kRingTop, 2, 3},
                                           {LayoutKind::kBillboard, 3, 8}};
  for (const ViewLayout& layout : layouts) {
    SCOPED_TRACE(::testing::Message() << LayoutName(layout.kind) << " " << layout.frames << " " << layout.ring_views);
    const std::vector<glm::vec3> a = HeldOutViewDirections(layout, "key-a", 16);
    ASSERT_EQ(a.size(), 16u);
    EXPECT_EQ(HeldOutViewDirections(layout, "key-a", 16), a);
    EXPECT_NE(HeldOutViewDirections(layout, "key-b", 16), a);
    const bool ring = layout.kind != LayoutKind::kAzimuthElevation;
    float lowest = 90.0f, highest = -90.0f;
    glm::vec3 mean(0.0f);
    for (const glm::vec3& d : a) {
      EXPECT_NEAR(glm::length(d), 1.0f, 1e-5f);
      lowest = std::min(lowest, ElevationDeg(d));
      highest = std::max(highest, ElevationDeg(d));
      mean += d / 16.0f;
      for (const FrameCamera& f : AtlasCameras(layout, GridSide(layout) * 8)) {
        const float degrees = std::acos(std::clamp(glm::dot(d, f.direction), -1.0f, 1.0f)) * kDegrees;
        ASSERT_GE(degrees, kMinDegreesFromFrame * 0.999f) << "frame " << f.index;
      }
    }
    if (ring) {
      // Elevations 0..60 (a nudge off a frame may add a degree or two).
      EXPECT_GE(lowest, 0.0f);
      EXPECT_LE(lowest, 10.0f);
      EXPECT_LE(highest, 62.0f);
      EXPECT_GE(highest, 45.0f);
      EXPECT_LT(glm::length(glm::vec3(mean.x, 0.0f, mean.z)), 0.2f) << "spread around in azimuth";
    } else {
      EXPECT_LT(lowest, -45.0f);
      EXPECT_GT(highest, 45.0f);
      EXPECT_LT(glm::length(mean), 0.2f);
    }
  }
}

class LayoutsQualityPass : public testing::SharedRendererTest {
 protected:
};

// A bake of each layout fills the manifest's quality block (it used to be
// skipped: "no reference renderer for the layout"). Floors are far below
// the measured figures (printed): they catch a broken pass, not a
// mediocre atlas.
TEST_F(LayoutsQualityPass, EveryLayoutGetsAQualityBlock) {
  struct Case {
    v1::Layout layout;
    uint32_t frames;      // 0 = derived
    uint32_t ring_views;  // 0 = unset
    uint32_t resolution;
  };
  const std::vector<Case> cases = {{v1::LAYOUT_AZIMUTH_ELEVATION, 7, 0, 448},
                                   {v1::LAYOUT_RING_TOP, 0, 12, 256},
                                   {v1::LAYOUT_BILLBOARD, 0, 0, 192}};
  for (const Case& c : cases) {
    v1::BakeParameters in;
    in.set_layout(c.layout);
    if (c.frames) in.set_frames(c.frames);
    if (c.ring_views) in.set_ring_views(c.ring_views);
    in.set_resolution(c.resolution);
    in.set_quality_views(8);
    auto p = NormalizeParameters(in);
    ASSERT_TRUE(p.ok()) << p.status();
    const std::string name(LayoutName(LayoutKindOf(c.layout)));
    const fs::path dir = fs::temp_directory_path() / ("impostor_layout_quality_" + name + "_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    const std::atomic<bool> cancelled{false};
    AtlasBakeRequest request{.entry_file = kHelmet, .parameters = *p, .cache_key = "layouts-" + name, .output_dir = dir};
    auto out = BakeAtlas(request, *renderer_, [](std::string_view, double) {}, cancelled);
    ASSERT_TRUE(out.ok()) << name << ": " << out.status();
    ASSERT_TRUE(out->manifest.has_quality()) << name;
    const v1::AtlasQuality& q = out->manifest.quality();
    std::printf("[ figures  ] helmet %s (%d frames, %u px): views %u x %u px; iou mean %.4f min %.4f; psnr mean "
                "%.2f min %.2f dB; ssim mean %.3f; normal mean %.2f deg; depth mean %.4f r; pop %.3f\n",
                name.c_str(), FrameCount(ViewLayoutOf(*p)), c.resolution, q.views(), q.view_pixels(),
                q.silhouette_iou_mean(), q.silhouette_iou_min(), q.albedo_psnr_union_db_mean(), q.albedo_psnr_union_db_min(),
                q.albedo_ssim_union_mean(), q.normal_error_deg_mean(), q.depth_error_mean(), q.pop());
    EXPECT_EQ(q.views(), 8u);
    EXPECT_GE(q.view_pixels(), 8u);
    EXPECT_LE(q.view_pixels(), 128u);
    EXPECT_GT(q.silhouette_iou_mean(), 0.6f) << name;
    EXPECT_LE(q.silhouette_iou_min(), q.silhouette_iou_mean());
    EXPECT_GT(q.albedo_psnr_union_db_mean(), 5.0f) << name;
    EXPECT_TRUE(std::isfinite(q.pop())) << name;
    EXPECT_TRUE(fs::exists(dir / kQualityWorstViewFile)) << name;
    fs::remove_all(dir);
  }
}

}  // namespace
}  // namespace impostor
