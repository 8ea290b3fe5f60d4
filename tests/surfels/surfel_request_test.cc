// Surfel bake requests: preset resolution, overrides, refused parameters,
// the cache key, and the manifest's surfels block on disk.
#include <gtest/gtest.h>

#include "common/request/bake_request.h"
#include "common/manifest/manifest_json.h"
#include "common/util/sha256.h"

namespace impostor {
namespace {

v1::MeshInput Mesh() {
  v1::MeshInput m;
  m.mutable_entry()->set_path("tree.glb");
  m.mutable_entry()->mutable_digest()->set_hash(Sha256Hex("glb"));
  m.mutable_entry()->mutable_digest()->set_size_bytes(3);
  return m;
}

v1::BakeParameters Surfels(const std::string& preset = "") {
  v1::BakeParameters p;
  p.set_product(v1::PRODUCT_SURFELS);
  p.set_preset(preset);
  return p;
}

TEST(SurfelRequest, PresetTableIsHonoured) {
  struct Case {
    const char* preset;
    uint32_t budget, frames, resolution;
  } cases[] = {
      {"prop", 2048, 12, 512},
      {"building", 16384, 16, 1024},
      {"vegetation", 32768, 24, 2048},
      {"hero", 65536, 32, 2048},
      {"", 32768, 24, 2048},  // no preset: vegetation
  };
  for (const Case& c : cases) {
    auto p = NormalizeParameters(Surfels(c.preset));
    ASSERT_TRUE(p.ok()) << c.preset << ": " << p.status();
    EXPECT_EQ(p->product(), v1::PRODUCT_SURFELS) << c.preset;
    EXPECT_EQ(p->point_budget(), c.budget) << c.preset;
    EXPECT_EQ(p->frames(), c.frames) << c.preset;
    EXPECT_EQ(p->resolution(), c.resolution) << c.preset;
    EXPECT_EQ(p->layout(), v1::LAYOUT_OCTAHEDRAL) << c.preset << ": full sphere by default";
    EXPECT_TRUE(p->preset().empty()) << c.preset << ": resolved presets are cleared";
  }
}

TEST(SurfelRequest, ExplicitParametersOverrideThePreset) {
  v1::BakeParameters in = Surfels("building");
  in.set_point_budget(5000);
  in.set_frames(10);
  in.set_resolution(1000);  // not a power of two
  auto p = NormalizeParameters(in);
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(p->point_budget(), 5000u);
  EXPECT_EQ(p->frames(), 10u);
  EXPECT_EQ(p->resolution(), 1000u);
}

TEST(SurfelRequest, BadParametersAreRefusedNamingFieldAndLimit) {
  struct Case {
    const char* name;
    v1::BakeParameters in;
    std::string expect;
  };
  auto with = [](v1::BakeParameters p, auto&& edit) {
    edit(p);
    return p;
  };
  const Case cases[] = {
      {"zero budget", with(Surfels(), [](auto& p) { p.set_point_budget(0); }),
       "parameters.point_budget: 0 is out of range 1..4194304"},
      {"absurd budget", with(Surfels(), [](auto& p) { p.set_point_budget(100'000'000); }),
       "parameters.point_budget: 100000000 is out of range 1..4194304"},
      {"one frame", with(Surfels(), [](auto& p) { p.set_frames(1); }),
       "parameters.frames: 1 is out of range 2..64"},
      {"too many frames", with(Surfels(), [](auto& p) { p.set_frames(65); }),
       "parameters.frames: 65 is out of range 2..64"},
      {"tiles too small", with(Surfels(), [](auto& p) { p.set_frames(64), p.set_resolution(500); }),
       "at least 8 are needed (resolution >= 512)"},
      {"unknown preset", Surfels("forest"),
       "parameters.preset: unknown preset \"forest\"; expected prop, building, vegetation or hero"},
      // Echoed in part: a status travels in a header with a size limit.
      {"a 100 000-byte preset", Surfels(std::string(100'000, 'x')),
       "parameters.preset: unknown preset \"" + std::string(80, 'x') + "...\"; expected prop"},
      {"unknown product", with(v1::BakeParameters(), [](auto& p) { p.set_product(static_cast<v1::Product>(7)); }),
       "parameters.product: unknown value 7"},
      {"budget on an atlas", with(v1::BakeParameters(), [](auto& p) { p.set_point_budget(2048); }),
       "parameters.point_budget: only for product PRODUCT_SURFELS"},
      {"preset on an atlas", with(v1::BakeParameters(), [](auto& p) { p.set_preset("prop"); }),
       "parameters.preset: \"prop\" is only for product PRODUCT_SURFELS"},
  };
  for (const Case& c : cases) {
    auto p = NormalizeParameters(c.in);
    ASSERT_FALSE(p.ok()) << c.name;
    EXPECT_EQ(p.status().code(), absl::StatusCode::kInvalidArgument) << c.name;
    EXPECT_NE(p.status().message().find(c.expect), std::string::npos) << c.name << ": " << p.status();
  }
}

TEST(SurfelRequest, ProductAndBudgetEnterTheCacheKeyAndAtlasKeysStay) {
  auto key = [](const v1::BakeParameters& in) { return ComputeCacheKey(Mesh(), *NormalizeParameters(in)); };
  v1::BakeParameters atlas;
  atlas.set_frames(24);
  atlas.set_resolution(2048);
  v1::BakeParameters explicit_atlas = atlas;
  explicit_atlas.set_product(v1::PRODUCT_ATLAS);
  EXPECT_EQ(key(atlas), key(explicit_atlas)) << "PRODUCT_ATLAS is the default";

  // The atlas key is the one computed before products existed: no product
  // line for atlases.
  v1::BakeParameters legacy = *NormalizeParameters(atlas);
  legacy.clear_product();
  EXPECT_EQ(ComputeCacheKey(Mesh(), legacy), key(atlas));

  // Same capture numbers, other product: another result.
  EXPECT_NE(key(Surfels()), key(atlas));
  v1::BakeParameters fewer = Surfels();
  fewer.set_point_budget(1000);
  EXPECT_NE(key(fewer), key(Surfels())) << "the budget is part of the key";
  // A preset and its numbers given explicitly share one result.
  v1::BakeParameters spelled_out = Surfels();
  spelled_out.set_point_budget(2048);
  spelled_out.set_frames(12);
  spelled_out.set_resolution(512);
  EXPECT_EQ(key(spelled_out), key(Surfels("prop")));
}

TEST(SurfelManifest, SurfelsBlockRoundTripsThroughJson) {
  v1::Manifest m;
  m.set_format_version(kManifestFormatVersion);
  m.set_cache_key(std::string(64, 'a'));
  m.set_baker_version("test");
  m.set_product(v1::PRODUCT_SURFELS);
  m.set_layout(v1::LAYOUT_OCTAHEDRAL);
  m.set_frames(12);
  m.set_resolution(512);
  m.set_tile_size(42);
  m.mutable_mesh()->set_triangles(778);
  for (float c : {0.0f, 1.0f, 2.0f}) m.mutable_bounding_sphere()->add_center(c);
  m.mutable_bounding_sphere()->set_radius(3.0f);
  v1::MapFile* map = m.add_maps();
  map->set_semantic("surfels");
  map->set_file("surfels.bin");
  map->mutable_digest()->set_hash(std::string(64, 'b'));
  map->mutable_digest()->set_size_bytes(48 * 100);
  map->set_width(100);
  map->set_height(1);
  map->set_format("f32x12_le");
  map->add_channels("f0..2: position");
  v1::SurfelCloud* s = m.mutable_surfels();
  s->set_file("surfels.bin");
  *s->mutable_digest() = map->digest();
  s->set_ply_file("surfels.ply");
  s->mutable_ply_digest()->set_hash(std::string(64, 'c'));
  s->mutable_ply_digest()->set_size_bytes(4321);
  s->set_point_count(100);
  s->set_point_budget(128);
  s->set_budget_fill(100.0f / 128.0f);
  s->set_voxel_size(0.25f);
  s->set_point_diameter(0.25f * 1.41421356f);
  for (float v : {-1.0f, -2.0f, -3.0f}) s->add_bounds_min(v);
  for (float v : {1.0f, 2.0f, 3.0f}) s->add_bounds_max(v);
  s->set_stride_bytes(48);
  s->set_sample_count(123456);
  s->set_capture_layout(v1::LAYOUT_OCTAHEDRAL);
  s->set_capture_frames(12);
  s->set_capture_resolution(512);
  s->mutable_quality()->set_views(8);
  s->mutable_quality()->set_view_pixels(64);
  s->mutable_quality()->set_silhouette_iou_mean(0.9f);
  s->mutable_quality()->set_silhouette_iou_min(0.8f);
  s->mutable_quality()->set_albedo_psnr_db(30.0f);

  const std::string json = ManifestToJson(m);
  EXPECT_NE(json.find("\"product\": \"surfels\""), std::string::npos) << json;
  auto back = ManifestFromJson(json);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->SerializeAsString(), m.SerializeAsString()) << back->DebugString();
}

TEST(SurfelManifest, AtlasManifestsSayAtlasAndOldOnesStillRead) {
  v1::Manifest m;
  m.set_format_version(kManifestFormatVersion);
  m.set_layout(v1::LAYOUT_OCTAHEDRAL);
  m.mutable_bounding_sphere()->add_center(0);
  m.mutable_bounding_sphere()->add_center(0);
  m.mutable_bounding_sphere()->add_center(0);
  m.mutable_bounding_sphere()->set_radius(1);
  std::string json = ManifestToJson(m);
  EXPECT_NE(json.find("\"product\": \"atlas\""), std::string::npos) << json;
  EXPECT_EQ(json.find("\"surfels\""), std::string::npos) << "no surfels block on an atlas";
  auto back = ManifestFromJson(json);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->product(), v1::PRODUCT_ATLAS);

  // A manifest written before products existed has no "product".
  const size_t at = json.find("  \"product\": \"atlas\",\n");
  ASSERT_NE(at, std::string::npos);
  json.erase(at, std::string("  \"product\": \"atlas\",\n").size());
  auto old = ManifestFromJson(json);
  ASSERT_TRUE(old.ok()) << old.status();
  EXPECT_EQ(old->product(), v1::PRODUCT_UNSPECIFIED);

  // A surfel manifest without its block is refused, naming it.
  std::string broken = ManifestToJson(m);
  broken.replace(broken.find("\"atlas\""), 7, "\"surfels\"");
  auto refused = ManifestFromJson(broken);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("surfels"), std::string::npos) << refused.status();
}

}  // namespace
}  // namespace impostor
