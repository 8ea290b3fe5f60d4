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
#include "tests/quality/in_memory_atlas.h"
#include "tests/support/procedural_tree.h"
#include "worker/bake/atlas_bake.h"
#include "worker/bake/quality_pass.h"
#include "worker/scene/gltf_loader.h"

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

// The IoU reference (quality_pass.h): the mesh's own one-sample views
// against its 3 x 3 ones. A solid prop's smooth edges split the same way
// either way; the tree's leaves and twigs, narrower than a pixel, do not, so
// sampling alone costs its silhouette IoU, whatever draws it. Measured on
// lavapipe (8 x 8 octahedral at 1024 px, 64 px views): the tree 0.851
// (worst view 0.791; its impostor 0.716), the bottle 1.000.
TEST_F(ProceduralTreeQualityTest, TheIouReferenceShowsWhatSamplingAloneCostsTheTree) {
  const fs::path dir = fs::temp_directory_path() / "procedural_tree_iou_reference";
  fs::create_directories(dir);
  ASSERT_TRUE(testing::WriteProceduralTree(dir / "tree.glb").ok());
  const fs::path bottle = fs::path(IMPOSTOR_TEST_ASSETS_DIR) / "props_pbr/WaterBottle/glTF/WaterBottle.gltf";
  double reference[2] = {-1, -1};
  int k = 0;
  for (const fs::path& file : {dir / "tree.glb", bottle}) {
    auto scene = LoadGltfScene(file);
    ASSERT_TRUE(scene.ok()) << scene.status();
    auto atlas = testing::InMemoryOctahedralAtlas(*scene, 8, 1024, *renderer_);
    ASSERT_TRUE(atlas.ok()) << atlas.status();
    QualityPassOptions o;
    o.view_pixels = 64;
    o.orbit_steps = 0;
    o.also_plain = false;
    auto without = MeasureAtlasQuality(*scene, *atlas, "iou-reference", o, *renderer_);
    ASSERT_TRUE(without.ok()) << without.status();
    EXPECT_EQ(without->one_sample_mesh_iou_mean, -1) << "measured only when asked (bench/quality_table)";
    o.pop_references = true;
    auto with = MeasureAtlasQuality(*scene, *atlas, "iou-reference", o, *renderer_);
    ASSERT_TRUE(with.ok()) << with.status();
    std::printf("%s: one-sample mesh IoU %.4f (worst %.4f), impostor %.4f\n", file.filename().c_str(),
                with->one_sample_mesh_iou_mean, with->one_sample_mesh_iou_min, with->quality.silhouette_iou_mean());
    EXPECT_LE(with->one_sample_mesh_iou_min, with->one_sample_mesh_iou_mean);
    // The impostor's own figures do not depend on the reference.
    EXPECT_EQ(with->quality.silhouette_iou_mean(), without->quality.silhouette_iou_mean());
    reference[k++] = with->one_sample_mesh_iou_mean;
  }
  EXPECT_LT(reference[0], 0.95) << "the tree";
  EXPECT_GT(reference[0], 0.75) << "the tree";
  EXPECT_GE(reference[1], 0.995) << "the bottle";
  fs::remove_all(dir);
}

}  // namespace
}  // namespace impostor
