// The whole LOD chain bake through the real renderer (Mesa lavapipe
// suffices): the levels in order with their files and digests, the
// impostor's atlas manifest, textures stored once, thresholds that shrink as
// the error grows, every .glb valid, and bad meshes refused.
#include "tests/gpu/shared_renderer_test.h"
#include "worker/bake/lod_bake.h"

#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <gtest/gtest.h>

#include "common/request/bake_request.h"
#include "common/manifest/manifest_json.h"
#include "common/util/sha256.h"
#include "tests/scene/test_assets.h"
#include "worker/lod/lod_thresholds.h"
#ifdef IMPOSTOR_HAVE_LOD_SDK
#include "impostor/lod.h"
#endif

namespace impostor {
namespace {

namespace fs = std::filesystem;

std::string ReadAll(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class LodBakeTest : public testing::SharedRendererTest {
 protected:

  static absl::StatusOr<AtlasBakeOutput> Bake(const fs::path& entry, const fs::path& out, int quality_views = 0,
                                              int resolution = 128, int frames = 4) {
    v1::BakeParameters in;
    in.set_product(v1::PRODUCT_LOD_CHAIN);
    in.set_frames(frames);
    in.set_resolution(resolution);
    in.set_quality_views(quality_views);
    auto p = NormalizeParameters(in);
    EXPECT_TRUE(p.ok()) << p.status();
    fs::create_directories(out);
    AtlasBakeRequest request{.entry_file = entry, .parameters = *p, .cache_key = std::string(64, 'c'),
                             .output_dir = out, .load_limits = {}};
    const std::atomic<bool> cancelled{false};
    return BakeLodChain(request, *renderer_, [](std::string_view, double) {}, cancelled);
  }

};

TEST_F(LodBakeTest, TreeChainHasOrderedLevelsSharedTexturesAndThresholds) {
  const fs::path dir = testing::MakeScratchDir("lod_bake_tree");
  auto out = Bake(testing::Asset("vegetation/TreeLowPoly_RicardoSanchez/scene_alphaMASK.gltf"), dir);
  ASSERT_TRUE(out.ok()) << out.status();
  const v1::Manifest& m = out->manifest;
  EXPECT_EQ(m.product(), v1::PRODUCT_LOD_CHAIN);
  EXPECT_EQ(m.layout(), v1::LAYOUT_HEMI_OCTAHEDRAL) << "the lod-chain default";
  ASSERT_EQ(m.lods_size(), 4);
  const char* kinds[] = {"mesh", "mesh", "mesh", "impostor"};
  const char* files[] = {"lod0.glb", "lod1.glb", "lod2.glb", "impostor.json"};
  for (int i = 0; i < 4; ++i) {
    const v1::LodLevel& l = m.lods(i);
    SCOPED_TRACE(files[i]);
    EXPECT_EQ(l.level(), static_cast<uint32_t>(i));
    EXPECT_EQ(l.kind(), kinds[i]);
    EXPECT_EQ(l.file(), files[i]);
    auto digest = DigestFile(dir / l.file());
    ASSERT_TRUE(digest.ok()) << digest.status();
    EXPECT_EQ(digest->hash, l.digest().hash());
    EXPECT_EQ(digest->size_bytes, l.digest().size_bytes());
    std::cout << "figures level=" << i << " kind=" << l.kind() << " triangles=" << l.triangles()
              << " ratio=" << l.target_ratio() << " error=" << l.error() << " threshold=" << l.threshold()
              << " sloppy=" << l.sloppy() << " bytes=" << l.digest().size_bytes() << "\n";
  }
  EXPECT_EQ(m.lods(0).triangles(), 778u);
  EXPECT_EQ(m.lods(3).triangles(), 2u);
  // Thresholds: non-increasing, 0 last; the next level's error meets the
  // 1 px budget at each mesh switch unless the impostor's 16 px rule comes
  // first; and as the error grows the threshold shrinks.
  const float radius = m.bounding_sphere().radius();
  const float impostor = kImpostorDiameterPixels / (2.0f * radius);
  for (int i = 0; i < 3; ++i) {
    EXPECT_GE(m.lods(i).threshold(), m.lods(i + 1).threshold()) << "level " << i;
    EXPECT_GE(m.lods(i + 1).error(), m.lods(i).error() * (i + 1 < 3 ? 1.0f : 0.0f)) << "level " << i;
  }
  EXPECT_EQ(m.lods(3).threshold(), 0.0f);
  EXPECT_FLOAT_EQ(m.lods(2).threshold(), impostor);
  // Mesh levels whose threshold equals the one before are never drawn, and
  // the manifest says which.
  std::string never_drawn_warning;
  for (const std::string& w : m.warnings()) {
    if (w.find("never drawn") != std::string::npos) never_drawn_warning = w;
  }
  bool any_never_drawn = false;
  for (int i = 1; i < 3; ++i) {
    const bool never = m.lods(i).threshold() >= m.lods(i - 1).threshold();
    any_never_drawn = any_never_drawn || never;
    EXPECT_EQ(never_drawn_warning.find("lod" + std::to_string(i)) != std::string::npos, never)
        << "level " << i << ": " << never_drawn_warning;
  }
  EXPECT_EQ(!never_drawn_warning.empty(), any_never_drawn) << never_drawn_warning;
  for (int i = 0; i < 2; ++i) {
    EXPECT_FLOAT_EQ(m.lods(i).threshold(), std::max(1.0f / m.lods(i + 1).error(), m.lods(i + 1).threshold()))
        << "level " << i;
  }

  // Every file listed once, present, with its digest; nothing else but
  // manifest.json left in the directory.
  std::map<std::string, int> listed;
  for (const v1::MapFile& f : m.maps()) {
    ++listed[f.file()];
    auto digest = DigestFile(dir / f.file());
    ASSERT_TRUE(digest.ok()) << f.file();
    EXPECT_EQ(digest->hash, f.digest().hash()) << f.file();
  }
  for (const auto& [file, n] : listed) EXPECT_EQ(n, 1) << file;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    EXPECT_TRUE(e.is_regular_file()) << name << " is not a plain file";
    EXPECT_TRUE(listed.count(name) || name == "manifest.json") << name << " not listed";
  }
  // The input's two images, once each, shared by the three levels.
  int textures = 0;
  for (const v1::MapFile& f : m.maps()) textures += f.semantic() == "lod_texture";
  EXPECT_EQ(textures, 2);
  for (const char* s : {"albedo_alpha", "normal_depth", "orm", "impostor_manifest"}) {
    EXPECT_TRUE(std::any_of(m.maps().begin(), m.maps().end(), [&](const v1::MapFile& f) { return f.semantic() == s; }))
        << s;
  }

  // impostor.json is an atlas manifest; manifest.json reads back equal.
  auto impostor_manifest = ManifestFromJson(ReadAll(dir / "impostor.json"));
  ASSERT_TRUE(impostor_manifest.ok()) << impostor_manifest.status();
  EXPECT_NE(impostor_manifest->product(), v1::PRODUCT_LOD_CHAIN);
  EXPECT_EQ(impostor_manifest->frames(), 4u);
  auto back = ManifestFromJson(ReadAll(out->manifest_path));
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->lods_size(), 4);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(back->lods(i).SerializeAsString(), m.lods(i).SerializeAsString());

  // Every level validates.
  for (int i = 0; i < 3; ++i) {
    const fs::path glb = dir / m.lods(i).file();
    // Bounded: `timeout` ends a hung validator (exit 124).
    const std::string cmd = "timeout 300 " + std::string(IMPOSTOR_GLTF_VALIDATOR) + " '" + glb.string() + "' > /dev/null";
    const int rc = std::system(cmd.c_str());
    EXPECT_TRUE(WIFEXITED(rc) && WEXITSTATUS(rc) == 0) << glb << ": validator exit " << (WIFEXITED(rc) ? WEXITSTATUS(rc) : -1);
  }

#ifdef IMPOSTOR_HAVE_LOD_SDK
  auto chain = sdk::LoadLodChain(out->manifest_path);
  ASSERT_TRUE(chain.ok()) << chain.status();
  ASSERT_EQ(chain->levels.size(), 4u);
  EXPECT_EQ(sdk::SelectLod(*chain, 1e-3f * radius, 1.0f, 1080.0f, -1), 0);
  EXPECT_EQ(sdk::SelectLod(*chain, 1e6f * radius, 1.0f, 1080.0f, -1), 3);
  EXPECT_TRUE(fs::exists(chain->LevelPath(1)));
#endif
  fs::remove_all(dir);
}

TEST_F(LodBakeTest, HelmetThresholdsShrinkAsErrorGrows) {
  const fs::path dir = testing::MakeScratchDir("lod_bake_helmet");
  auto out = Bake(testing::Asset("props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb"), dir);
  ASSERT_TRUE(out.ok()) << out.status();
  const v1::Manifest& m = out->manifest;
  ASSERT_EQ(m.lods_size(), 4);
  for (int i = 0; i < 4; ++i) {
    const v1::LodLevel& l = m.lods(i);
    std::cout << "figures helmet level=" << i << " triangles=" << l.triangles() << " error=" << l.error()
              << " threshold=" << l.threshold() << " sloppy=" << l.sloppy() << " bytes=" << l.digest().size_bytes()
              << " switch_distance_1080p_60deg="
              << (l.threshold() > 0 ? 1080.0f / (2.0f * std::tan(0.5236f) * l.threshold()) : 0.0f) << "\n";
  }
  // Distinct errors give distinct switches: strictly shrinking thresholds.
  EXPECT_LT(m.lods(1).error(), m.lods(2).error());
  EXPECT_GT(m.lods(0).threshold(), m.lods(1).threshold());
  EXPECT_GT(m.lods(1).threshold(), m.lods(2).threshold());
  EXPECT_FLOAT_EQ(m.lods(0).threshold(), 1.0f / m.lods(1).error());
  EXPECT_FLOAT_EQ(m.lods(1).threshold(), 1.0f / m.lods(2).error());
  for (const std::string& w : m.warnings()) EXPECT_EQ(w.find("never drawn"), std::string::npos) << w;
  // The five embedded JPEGs become five texture files, stored once.
  int textures = 0;
  for (const v1::MapFile& f : m.maps()) textures += f.semantic() == "lod_texture";
  EXPECT_EQ(textures, 5);
  fs::remove_all(dir);
}

// Issue 43: with its quality pass, the impostor takes over below the size
// the pass found it good for (the bounding sphere's diameter on screen),
// not the fixed 16 px; a chain whose impostor is good at no measured size
// keeps the fixed rule and says so.
TEST_F(LodBakeTest, TheImpostorTakesOverBelowItsGoodForSize) {
  const fs::path dir = testing::MakeScratchDir("lod_bake_good_for");
  auto out = Bake(testing::Asset("props_pbr/Duck/glTF-Binary/Duck.glb"), dir, /*quality_views=*/4,
                  /*resolution=*/512, /*frames=*/8);
  ASSERT_TRUE(out.ok()) << out.status();
  const v1::Manifest& m = out->manifest;
  ASSERT_GE(m.lods_size(), 2);
  const v1::AtlasQuality& q = m.quality();
  ASSERT_GT(q.sizes_size(), 0) << "the impostor's quality pass measures its sizes";
  const float radius = m.bounding_sphere().radius();
  const v1::LodLevel& last_mesh = m.lods(m.lods_size() - 2);
  std::cout << "figures good_up_to_pixels=" << q.good_up_to_pixels() << " last_mesh_threshold=" << last_mesh.threshold()
            << "\n";
  bool warned = false;
  for (const std::string& w : m.warnings()) warned = warned || w.find("good-for targets at no measured size") != std::string::npos;
  if (q.good_up_to_pixels() > 0) {
    EXPECT_FLOAT_EQ(last_mesh.threshold(), static_cast<float>(q.good_up_to_pixels()) / (2.0f * radius));
    EXPECT_FALSE(warned);
  } else {
    EXPECT_FLOAT_EQ(last_mesh.threshold(), kImpostorDiameterPixels / (2.0f * radius));
    EXPECT_TRUE(warned);
  }
  // A duck at 8 x 8 frames of 64 px is good well beyond 16 px.
  EXPECT_GT(q.good_up_to_pixels(), static_cast<uint32_t>(kImpostorDiameterPixels));
  fs::remove_all(dir);
}

TEST_F(LodBakeTest, RefusesASceneWithoutTriangles) {
  const fs::path dir = testing::MakeScratchDir("lod_bake_empty");
  testing::TriangleOptions options;
  options.scene_nodes = "[]";
  testing::WriteFile(dir / "empty.gltf", testing::TriangleGltf(options));
  auto out = Bake(dir / "empty.gltf", dir / "out");
  ASSERT_FALSE(out.ok());
  EXPECT_EQ(out.status().code(), absl::StatusCode::kInvalidArgument) << out.status();
  fs::remove_all(dir);
}

}  // namespace
}  // namespace impostor
