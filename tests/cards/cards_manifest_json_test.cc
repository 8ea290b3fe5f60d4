// The `cards` block of manifest.json: written, read back unchanged, and
// malformed blocks refused with the key at fault.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "common/manifest/manifest_json.h"

namespace impostor {
namespace {

v1::Manifest CardsManifest() {
  v1::Manifest m;
  m.set_format_version(kManifestFormatVersion);
  m.set_product(v1::PRODUCT_CARDS);
  m.set_layout(v1::LAYOUT_OCTAHEDRAL);
  m.set_resolution(512);
  for (int i = 0; i < 3; ++i) m.mutable_bounding_sphere()->add_center(0.5f * i);
  m.mutable_bounding_sphere()->set_radius(2);
  v1::CardCluster* c = m.mutable_cards();
  c->set_file("cards.glb");
  c->mutable_digest()->set_hash(std::string(64, 'a'));
  c->mutable_digest()->set_size_bytes(1234);
  for (int p = 0; p < 2; ++p) {
    v1::CardPlane* plane = c->add_planes();
    for (float f : {0.0f, 1.0f * p, 1.0f - p, -0.25f}) plane->add_plane(f);
    v1::Card* card = c->add_cards();
    for (int k = 0; k < 12; ++k) card->add_corners(0.125f * k);
    card->set_triangles(3 + p);
    card->set_texels(1000 + p);
    card->mutable_tile()->set_x(2);
    card->mutable_tile()->set_y(2 + 40 * p);
    card->mutable_tile()->set_width(30);
    card->mutable_tile()->set_height(20);
    card->set_max_distance(0.01f);
    card->set_mean_distance(0.005f);
  }
  for (uint32_t t : {0u, 0u, 1u, 0u, 1u, 1u, 1u}) c->add_triangle_plane(t);
  c->set_tolerance(0.1f);
  c->set_max_distance(0.01f);
  c->set_mean_distance(0.004f);
  c->set_budget_exhausted(true);
  c->set_triangles(4);
  c->mutable_quality()->set_views(16);
  c->mutable_quality()->set_silhouette_iou_mean(0.9f);
  c->mutable_quality()->set_silhouette_iou_min(0.8f);
  c->mutable_quality()->set_albedo_psnr_db(30);
  return m;
}

TEST(CardsManifestJson, RoundTrips) {
  const v1::Manifest m = CardsManifest();
  const std::string text = ManifestToJson(m);
  EXPECT_NE(text.find("\"product\": \"cards\""), std::string::npos);
  auto back = ManifestFromJson(text);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->product(), v1::PRODUCT_CARDS);
  EXPECT_EQ(back->cards().SerializeAsString(), m.cards().SerializeAsString());
}

TEST(CardsManifestJson, MalformedBlocksNameTheKey) {
  struct Case {
    const char* name;
    void (*mutate)(nlohmann::json&);
    const char* expect;
  } cases[] = {
      {"no block", [](nlohmann::json& j) { j.erase("cards"); }, "cards: missing"},
      {"short plane", [](nlohmann::json& j) { j["cards"]["planes"][1] = {0, 1, 0}; }, "cards.planes[1]"},
      {"plane out of range", [](nlohmann::json& j) { j["cards"]["triangle_plane"][2] = 7; }, "plane 7 does not exist"},
      {"corners", [](nlohmann::json& j) { j["cards"]["cards"][0]["corners"] = {1, 2, 3}; },
       "cards.cards[0].corners"},
      {"digest", [](nlohmann::json& j) { j["cards"]["digest"].erase("hash"); }, "cards.digest"},
  };
  for (const Case& c : cases) {
    nlohmann::json j = nlohmann::json::parse(ManifestToJson(CardsManifest()));
    c.mutate(j);
    auto back = ManifestFromJson(j.dump());
    ASSERT_FALSE(back.ok()) << c.name;
    EXPECT_EQ(back.status().code(), absl::StatusCode::kInvalidArgument) << c.name;
    EXPECT_NE(back.status().message().find(c.expect), std::string::npos) << c.name << ": " << back.status();
  }
}

}  // namespace
}  // namespace impostor
