// cards.glb: a standard glTF 2.0 binary the Khronos validator accepts, and
// that loads back as the cards it was made of.
#include "worker/cards/cards_glb.h"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "tests/cards/validator.h"
#include "tests/scene/test_assets.h"
#include "worker/scene/gltf_loader.h"

namespace impostor {
namespace {

std::string Png(int size, std::vector<uint16_t> rgba) {
  std::vector<uint16_t> samples;
  for (int i = 0; i < size * size; ++i) samples.insert(samples.end(), rgba.begin(), rgba.end());
  const std::vector<uint8_t> bytes = testing::MakePng(size, size, 4, 8, samples);
  return std::string(bytes.begin(), bytes.end());
}

CardsGlbInput TwoCards() {
  CardsGlbInput in;
  CardRect a;
  a.center = {0, 1, 0};
  a.u = {1, 0, 0};
  a.v = {0, 1, 0};
  a.normal = {0, 0, 1};
  a.half_u = 1;
  a.half_v = 0.5f;
  CardRect b = a;
  b.u = {0, 0, -1};
  b.normal = {1, 0, 0};
  in.cards = {a, b};
  in.tiles = {{2, 2, 28, 14}, {2, 20, 28, 14}};
  in.atlas_size = 32;
  in.albedo_png = Png(32, {200, 120, 40, 255});
  in.normal_png = Png(32, {128, 128, 255, 255});
  in.orm_png = Png(32, {255, 200, 0, 255});
  return in;
}

TEST(CardsGlb, KhronosValidatorReportsNoErrors) {
  auto glb = EncodeCardsGlb(TwoCards());
  ASSERT_TRUE(glb.ok()) << glb.status();
  const auto dir = testing::MakeScratchDir("cards_glb");
  testing::WriteFile(dir / "cards.glb", *glb);
  const testing::ValidatorResult v = testing::RunGltfValidator(dir / "cards.glb");
  EXPECT_EQ(v.exit_code, 0) << v.report;
  EXPECT_NE(v.report.find("\"numErrors\": 0"), std::string::npos) << v.report;
}

TEST(CardsGlb, LoadsBackAsTwoTrianglesPerCardWithAMaskedDoubleSidedMaterial) {
  auto glb = EncodeCardsGlb(TwoCards());
  ASSERT_TRUE(glb.ok()) << glb.status();
  auto scene = LoadGltfSceneFromMemory(*glb, "cards.glb");
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_EQ(scene->TriangleCount(), 4u);
  ASSERT_EQ(scene->materials.size(), 1u);
  EXPECT_EQ(scene->materials[0].alpha_mode, AlphaMode::kMask);
  EXPECT_TRUE(scene->materials[0].double_sided);
  EXPECT_GE(scene->materials[0].base_color_texture, 0);
  EXPECT_GE(scene->materials[0].normal_texture, 0);
  EXPECT_EQ(scene->materials[0].occlusion_texture, scene->materials[0].metallic_roughness_texture);
  // The first corner, (-u, -v) of card 0, samples the tile's bottom-left.
  EXPECT_NEAR(scene->vertices[scene->indices[0]].uv.x, 2.0f / 32, 1e-6f);
  EXPECT_NEAR(scene->vertices[scene->indices[0]].uv.y, 16.0f / 32, 1e-6f);
  const glm::vec3 p = scene->vertices[scene->indices[0]].position;
  EXPECT_NEAR(glm::length(p - glm::vec3(-1, 0.5f, 0)), 0.0f, 1e-6f);
}

TEST(CardsGlb, MismatchedInputIsRefused) {
  CardsGlbInput in = TwoCards();
  in.tiles.pop_back();
  EXPECT_EQ(EncodeCardsGlb(in).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(EncodeCardsGlb(CardsGlbInput{}).status().code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace impostor
