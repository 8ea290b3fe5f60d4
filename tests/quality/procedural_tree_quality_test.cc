// Issue 43's tree with thin branches, baked at the target configuration
// (hemi-octahedral 12 x 12, 2048 px, depth mode) by the worker's own
// pipeline: the quality pass measures it like every asset of
// docs/quality.md, and the figures hold their measured floors.
//
// Measured on lavapipe (2026-12-03, baker 0.2.0-bake7): depth IoU mean
// 0.831, worst view 0.758 (plain 0.595), shared PSNR 34.6 dB, pop 1.07, pop
// antialiased 1.12, good up to 70 px. Issue 43's vegetation targets (IoU
// mean >= 0.95, worst >= 0.90) are not met: docs/quality.md says why. The
// floors sit a little under the measurement, so a change that loses the
// tree's leaves or twigs fails here.
#include <atomic>
#include <cstdio>
#include <filesystem>

#include <gtest/gtest.h>

#include "common/request/bake_request.h"
#include "tests/gpu/shared_renderer_test.h"
#include "tests/support/procedural_tree.h"
#include "worker/bake/atlas_bake.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

class ProceduralTreeQualityTest : public testing::SharedRendererTest {};

TEST_F(ProceduralTreeQualityTest, TheTargetConfigurationMeasuresTheThinBranches) {
  const fs::path dir = fs::temp_directory_path() / "procedural_tree_bake";
  fs::create_directories(dir / "out");
  auto tree = testing::WriteProceduralTree(dir / "tree.glb");
  ASSERT_TRUE(tree.ok()) << tree.status();

  v1::BakeParameters in;
  in.set_layout(v1::LAYOUT_HEMI_OCTAHEDRAL);
  in.set_frames(12);
  in.set_resolution(2048);
  auto p = NormalizeParameters(in);
  ASSERT_TRUE(p.ok()) << p.status();
  const std::atomic<bool> cancelled{false};
  AtlasBakeRequest request{.entry_file = dir / "tree.glb",
                           .parameters = *p,
                           .cache_key = "procedural_tree hemi-octahedral 12 2048",
                           .output_dir = dir / "out",
                           .load_limits = {}};
  auto baked = BakeAtlas(request, *renderer_, [](std::string_view, double) {}, cancelled);
  ASSERT_TRUE(baked.ok()) << baked.status();
  const v1::AtlasQuality& q = baked->manifest.quality();
  std::printf("procedural tree: IoU mean %.4f min %.4f, plain %.4f; PSNR %.2f dB; pop %.2f, pop AA %.2f; good up to "
              "%u px\n",
              q.silhouette_iou_mean(), q.silhouette_iou_min(), q.plain().silhouette_iou_mean(),
              q.albedo_psnr_shared_db_mean(), q.pop(), q.pop_antialiased(), q.good_up_to_pixels());
  EXPECT_EQ(q.views(), 16u);
  EXPECT_GE(q.silhouette_iou_mean(), 0.80);
  EXPECT_GE(q.silhouette_iou_min(), 0.72);
  EXPECT_GE(q.albedo_psnr_shared_db_mean(), 32.0);
  EXPECT_LE(q.pop_antialiased(), 1.5);
  // The plain reconstruction's flat planes smear a tree of twigs far more
  // than depth's: the default is the right one for foliage.
  EXPECT_GT(q.silhouette_iou_mean(), q.plain().silhouette_iou_mean() + 0.1);
  EXPECT_GE(q.good_up_to_pixels(), 45u);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace impostor
