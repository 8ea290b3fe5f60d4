// The card-cluster bake end to end through the real Vulkan renderer (Mesa
// lavapipe suffices): planes, the card atlas's pixels, cards.glb through the
// Khronos validator, the held-out-view quality and the manifest.
#include "tests/gpu/shared_renderer_test.h"
#include "worker/bake/cards_bake.h"

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "common/request/bake_request.h"
#include "common/manifest/manifest_json.h"
#include "tests/cards/card_geometry.h"
#include "tests/cards/validator.h"
#include "tests/scene/test_assets.h"
#include "worker/output/map_writer.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

class CardsBakeTest : public testing::SharedRendererTest {
 protected:

  static absl::StatusOr<AtlasBakeOutput> Bake(const fs::path& entry, uint32_t resolution, const fs::path& out,
                                               uint32_t max_planes = 0) {
    v1::BakeParameters in;
    in.set_product(v1::PRODUCT_CARDS);
    in.set_resolution(resolution);
    if (max_planes != 0) in.set_max_planes(max_planes);
    auto p = NormalizeParameters(in);
    if (!p.ok()) return p.status();
    AtlasBakeRequest request{.entry_file = entry, .parameters = *p, .cache_key = "test", .output_dir = out,
                             .load_limits = {}};
    const std::atomic<bool> cancelled{false};
    const auto start = std::chrono::steady_clock::now();
    auto result = BakeCards(request, *renderer_, [](std::string_view, double) {}, cancelled);
    if (result.ok()) {
      const v1::CardCluster& c = result->manifest.cards();
      std::printf(
          "[ figures  ] %s: %llu triangles -> %d cards (%u triangles), max_distance %.4g (tolerance %.4g), "
          "IoU mean %.4f min %.4f, albedo PSNR %.2f dB, %.2f s\n",
          entry.filename().c_str(), static_cast<unsigned long long>(result->manifest.mesh().triangles()),
          c.cards_size(), c.triangles(), c.max_distance(), c.tolerance(), c.quality().silhouette_iou_mean(),
          c.quality().silhouette_iou_min(), c.quality().albedo_psnr_db(),
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    }
    return result;
  }

  // The invariants of every card bake.
  static void ExpectSoundBake(const AtlasBakeOutput& out, const fs::path& dir, double min_iou) {
    const v1::Manifest& m = out.manifest;
    EXPECT_EQ(m.product(), v1::PRODUCT_CARDS);
    const v1::CardCluster& c = m.cards();
    ASSERT_GT(c.planes_size(), 0);
    EXPECT_EQ(c.cards_size(), c.planes_size());
    EXPECT_EQ(c.triangles(), 2u * c.cards_size());
    ASSERT_EQ(static_cast<uint64_t>(c.triangle_plane_size()), m.mesh().triangles()) << "every triangle assigned";
    for (uint32_t plane : c.triangle_plane()) ASSERT_LT(plane, static_cast<uint32_t>(c.planes_size()));
    if (!c.budget_exhausted()) {
      EXPECT_LE(c.max_distance(), c.tolerance() * 1.0001f);
    }
    uint64_t texels = 0;
    for (const v1::Card& card : c.cards()) {
      EXPECT_EQ(card.corners_size(), 12);
      texels += card.texels();
    }
    EXPECT_GT(texels, 0u) << "the card atlas has covered texels";
    EXPECT_GE(c.quality().views(), 16u);
    EXPECT_GE(c.quality().silhouette_iou_mean(), min_iou);
    // Every file the manifest lists is there with its digest's size; the
    // .glb passes the Khronos validator.
    for (const v1::MapFile& map : m.maps()) {
      ASSERT_TRUE(fs::exists(dir / map.file())) << map.file();
      EXPECT_EQ(static_cast<int64_t>(fs::file_size(dir / map.file())), map.digest().size_bytes()) << map.file();
    }
    EXPECT_EQ(c.file(), "cards.glb");
    const testing::ValidatorResult v = testing::RunGltfValidator(dir / c.file());
    EXPECT_EQ(v.exit_code, 0) << v.report;
    // manifest.json reads back to the same cards block.
    std::ifstream in(dir / "manifest.json");
    std::stringstream text;
    text << in.rdbuf();
    auto back = ManifestFromJson(text.str());
    ASSERT_TRUE(back.ok()) << back.status();
    EXPECT_EQ(back->product(), v1::PRODUCT_CARDS);
    EXPECT_EQ(back->cards().SerializeAsString(), c.SerializeAsString());
  }

};

TEST_F(CardsBakeTest, CrossedQuadsBecomeTwoExactCardsInTheirColour) {
  const fs::path dir = testing::MakeScratchDir("cards_crossed");
  const std::vector<Triangle3> soup = testing::Soup(
      {{{0.0f, 1.0f, 0.0f}, {0.0f, 0.0f, 1.0f}, {0.0f, 1.0f, 0.0f}, 4},
       {{0.0f, 1.0f, 0.3f}, {1.0f, 0.0f, 0.0f}, {0.0f, 0.5f, 0.0f}, 4}});
  const fs::path entry = testing::WriteSoupGltf(dir, soup, {0.8f, 0.2f, 0.1f, 1.0f});
  const fs::path out = dir / "out";
  fs::create_directories(out);
  auto result = Bake(entry, 256, out);
  ASSERT_TRUE(result.ok()) << result.status();
  ExpectSoundBake(*result, out, 0.95);
  const v1::CardCluster& c = result->manifest.cards();
  ASSERT_EQ(c.cards_size(), 2);
  EXPECT_LT(c.max_distance(), 1e-5f);
  EXPECT_FALSE(c.budget_exhausted());

  auto albedo = ReadPng(out / "albedo_alpha.png");
  ASSERT_TRUE(albedo.ok()) << albedo.status();
  ASSERT_EQ(albedo->width, 256);
  for (const v1::Card& card : c.cards()) {
    // A planar quad covers its whole card.
    const uint64_t area = static_cast<uint64_t>(card.tile().width()) * card.tile().height();
    EXPECT_GE(card.texels(), area * 95 / 100);
    const size_t centre = ((card.tile().y() + card.tile().height() / 2) * 256 + card.tile().x() +
                           card.tile().width() / 2) * 4;
    // linear (0.8, 0.2, 0.1) in sRGB is about (231, 124, 89).
    EXPECT_NEAR(albedo->pixels8[centre + 0], 231, 3);
    EXPECT_NEAR(albedo->pixels8[centre + 1], 124, 3);
    EXPECT_NEAR(albedo->pixels8[centre + 2], 89, 3);
    EXPECT_EQ(albedo->pixels8[centre + 3], 255);
    // The gutter just left of the card is empty but dilated.
    const size_t gutter = ((card.tile().y() + card.tile().height() / 2) * 256 + card.tile().x() - 1) * 4;
    EXPECT_EQ(albedo->pixels8[gutter + 3], 0);
    EXPECT_NEAR(albedo->pixels8[gutter + 0], 231, 3);
  }
}

TEST_F(CardsBakeTest, LowPolyTreeCardsPassTheValidator) {
  const fs::path entry = testing::Asset("vegetation/TreeLowPoly_RicardoSanchez/scene_alphaMASK.gltf");
  const fs::path out = testing::MakeScratchDir("cards_tree");
  auto result = Bake(entry, 512, out);
  ASSERT_TRUE(result.ok()) << result.status();
  ExpectSoundBake(*result, out, 0.5);
  EXPECT_EQ(result->manifest.cards().cards_size(), 8);
}

TEST_F(CardsBakeTest, TexturedPropCardsPassTheValidator) {
  const fs::path entry = testing::Asset("props_pbr/Avocado/glTF/Avocado.gltf");
  const fs::path out = testing::MakeScratchDir("cards_avocado");
  auto result = Bake(entry, 256, out);
  ASSERT_TRUE(result.ok()) << result.status();
  ExpectSoundBake(*result, out, 0.5);
}

// A box's faces are planar: six cards that coincide with them, so the cards
// must look like the mesh, texture orientation included.
TEST_F(CardsBakeTest, TexturedBoxBecomesSixCardsThatLookLikeIt) {
  const fs::path entry = testing::Asset("props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb");
  const fs::path out = testing::MakeScratchDir("cards_box");
  auto result = Bake(entry, 256, out);
  ASSERT_TRUE(result.ok()) << result.status();
  ExpectSoundBake(*result, out, 0.95);
  const v1::CardCluster& c = result->manifest.cards();
  EXPECT_EQ(c.cards_size(), 6);
  EXPECT_LT(c.max_distance(), 1e-5f);
  EXPECT_GE(c.quality().albedo_psnr_db(), 20.0f);
}

TEST_F(CardsBakeTest, BudgetOfOnePlaneIsReported) {
  const fs::path entry = testing::Asset("vegetation/TreeLowPoly_RicardoSanchez/scene_alphaMASK.gltf");
  const fs::path out = testing::MakeScratchDir("cards_tree_one");
  auto result = Bake(entry, 128, out, /*max_planes=*/1);
  ASSERT_TRUE(result.ok()) << result.status();
  const v1::CardCluster& c = result->manifest.cards();
  EXPECT_EQ(c.cards_size(), 1);
  EXPECT_TRUE(c.budget_exhausted());
  EXPECT_GT(c.max_distance(), c.tolerance());
  EXPECT_EQ(result->manifest.warnings_size(), 1);
}

}  // namespace
}  // namespace impostor
