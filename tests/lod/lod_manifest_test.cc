// The `lods` list in manifest.json: written, read back, malformed entries
// refused; and (with the SDK) LoadLodChain of the same file.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "common/manifest/manifest_json.h"
#ifdef IMPOSTOR_HAVE_LOD_SDK
#include "impostor/lod.h"
#endif

namespace impostor {
namespace {

v1::Manifest ChainManifest() {
  v1::Manifest m;
  m.set_format_version(kManifestFormatVersion);
  m.set_cache_key(std::string(64, 'a'));
  m.set_product(v1::PRODUCT_LOD_CHAIN);
  m.set_layout(v1::LAYOUT_HEMI_OCTAHEDRAL);
  m.set_frames(4);
  m.set_resolution(128);
  m.set_tile_size(32);
  for (float c : {0.0f, 1.0f, 0.0f}) m.mutable_bounding_sphere()->add_center(c);
  m.mutable_bounding_sphere()->set_radius(2.0f);
  const struct {
    const char* kind;
    const char* file;
    uint64_t triangles;
    float ratio, error, threshold;
    bool sloppy;
  } levels[] = {{"mesh", "lod0.glb", 1000, 1.0f, 0.0f, 500.0f, false},
                {"mesh", "lod1.glb", 500, 0.5f, 0.002f, 50.0f, false},
                {"mesh", "lod2.glb", 100, 0.1f, 0.02f, 4.0f, true},
                {"impostor", "impostor.json", 2, 0.0f, 0.0f, 0.0f, false}};
  uint32_t i = 0;
  for (const auto& l : levels) {
    v1::LodLevel* out = m.add_lods();
    out->set_level(i++);
    out->set_kind(l.kind);
    out->set_file(l.file);
    out->mutable_digest()->set_hash(std::string(64, 'b'));
    out->mutable_digest()->set_size_bytes(123);
    out->set_triangles(l.triangles);
    out->set_target_ratio(l.ratio);
    out->set_error(l.error);
    out->set_threshold(l.threshold);
    out->set_sloppy(l.sloppy);
  }
  return m;
}

TEST(LodManifestJsonTest, RoundTrips) {
  const v1::Manifest m = ChainManifest();
  const std::string json = ManifestToJson(m);
  EXPECT_NE(json.find("\"product\": \"lod-chain\""), std::string::npos);
  auto back = ManifestFromJson(json);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->product(), v1::PRODUCT_LOD_CHAIN);
  ASSERT_EQ(back->lods_size(), 4);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(back->lods(i).SerializeAsString(), m.lods(i).SerializeAsString()) << "level " << i;
  }
}

TEST(LodManifestJsonTest, RefusesMalformedLevels) {
  const struct {
    const char* name;
    std::string from, to;
    const char* expect;
  } cases[] = {
      {"missing threshold", "\"threshold\": 50.0", "\"thresh\": 50.0", "lods[1].threshold"},
      {"out of order", "\"level\": 2", "\"level\": 7", "lods[2].level"},
      {"unknown kind", "\"kind\": \"impostor\"", "\"kind\": \"cards\"", "lods[3].kind"},
  };
  const std::string json = ManifestToJson(ChainManifest());
  for (const auto& c : cases) {
    std::string bad = json;
    const size_t at = bad.find(c.from);
    ASSERT_NE(at, std::string::npos) << c.name;
    bad.replace(at, c.from.size(), c.to);
    auto m = ManifestFromJson(bad);
    ASSERT_FALSE(m.ok()) << c.name;
    EXPECT_EQ(m.status().code(), absl::StatusCode::kInvalidArgument) << c.name;
    EXPECT_NE(m.status().message().find(c.expect), std::string::npos) << c.name << ": " << m.status();
  }
}

#ifdef IMPOSTOR_HAVE_LOD_SDK
TEST(LodManifestJsonTest, SdkLoadsTheChain) {
  const auto dir = std::filesystem::temp_directory_path() / "lod_manifest_test";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "manifest.json") << ManifestToJson(ChainManifest());
  auto chain = sdk::LoadLodChain(dir / "manifest.json");
  ASSERT_TRUE(chain.ok()) << chain.status();
  ASSERT_EQ(chain->levels.size(), 4u);
  EXPECT_EQ(chain->levels[3].kind, sdk::LodLevelInfo::Kind::kImpostor);
  EXPECT_FLOAT_EQ(chain->levels[1].threshold, 50.0f);
  EXPECT_TRUE(chain->levels[2].sloppy);
  EXPECT_FLOAT_EQ(chain->radius, 2.0f);
  EXPECT_EQ(chain->LevelPath(1), dir / "lod1.glb");
  EXPECT_EQ(chain->good_up_to_pixels, 0u) << "no quality pass, no good-for size";

  // Issue 43: the impostor's good-for size reaches the SDK.
  std::ofstream(dir / "measured.json") << ManifestToJson([] {
    v1::Manifest m = ChainManifest();
    v1::AtlasQuality* q = m.mutable_quality();
    q->set_blend("triangle3");
    q->set_views(16);
    q->set_view_pixels(128);
    v1::SizeQuality* s = q->add_sizes();
    s->set_pixels(140);
    s->set_meets(true);
    q->set_good_up_to_pixels(140);
    return m;
  }());
  auto measured = sdk::LoadLodChain(dir / "measured.json");
  ASSERT_TRUE(measured.ok()) << measured.status();
  EXPECT_EQ(measured->good_up_to_pixels, 140u);

  std::ofstream(dir / "atlas.json") << ManifestToJson([] {
    v1::Manifest m = ChainManifest();
    m.set_product(v1::PRODUCT_ATLAS);
    return m;
  }());
  auto atlas = sdk::LoadLodChain(dir / "atlas.json");
  EXPECT_EQ(atlas.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(sdk::LoadLodChain(dir / "nope.json").status().code(), absl::StatusCode::kNotFound);
  std::filesystem::remove_all(dir);
}
#endif

}  // namespace
}  // namespace impostor
