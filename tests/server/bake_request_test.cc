#include "common/request/bake_request.h"

#include <cmath>
#include <optional>

#include <gtest/gtest.h>

#include "common/util/sha256.h"

namespace impostor {
namespace {

v1::InputFile File(const std::string& path, const std::string& content) {
  v1::InputFile f;
  f.set_path(path);
  f.mutable_digest()->set_hash(Sha256Hex(content));
  f.mutable_digest()->set_size_bytes(static_cast<int64_t>(content.size()));
  return f;
}

v1::MeshInput Gltf() {
  v1::MeshInput m;
  *m.mutable_entry() = File("tree.gltf", "{json}");
  *m.add_files() = File("tree.bin", "binary");
  *m.add_files() = File("textures/leaf.png", "png");
  return m;
}

TEST(BakeRequest, DefaultsAreFilledIn) {
  auto p = NormalizeParameters({});
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(p->layout(), v1::LAYOUT_OCTAHEDRAL);
  EXPECT_EQ(p->frames(), 12u);
  EXPECT_EQ(p->resolution(), 2048u);
}

TEST(BakeRequest, TwoFramesPerAxisAreRefusedOnlyWhereTheyFoldOntoOneView) {
  v1::BakeParameters hemi;
  hemi.set_layout(v1::LAYOUT_HEMI_OCTAHEDRAL);
  hemi.set_frames(2);
  EXPECT_TRUE(NormalizeParameters(hemi).ok()) << "the hemisphere's 2 x 2 are four side views";
  v1::BakeParameters octahedral;
  octahedral.set_frames(3);
  EXPECT_TRUE(NormalizeParameters(octahedral).ok());
  octahedral.set_frames(2);
  const auto refused = NormalizeParameters(octahedral);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("use 3 or more, or hemi-octahedral"), std::string::npos) << refused.status();
}

TEST(BakeRequest, OutOfRangeParametersNameTheFieldAndLimit) {
  struct Case {
    const char* name;
    uint32_t frames, resolution;
    int layout;
    const char* expect;
  } cases[] = {
      {"one frame", 1, 0, 0, "parameters.frames: 1 is out of range 2..64"},
      {"too many frames", 65, 0, 0, "parameters.frames: 65 is out of range 2..64"},
      // Octahedral's 2 x 2 grid is its four folded corners: one view, four times.
      {"octahedral 2 x 2", 2, 0, 0, "parameters.frames: octahedral needs at least 3 frames per axis"},
      {"tiny atlas", 0, 32, 0, "parameters.resolution: 32 is out of range 64..16384"},
      {"huge atlas", 0, 32768, 0, "parameters.resolution: 32768 is out of range 64..16384"},
      {"huge supersampled atlas", 0, 16384, 0,
       "parameters.supersampling: 2 x resolution 16384 = 32768 px exceeds the 16384 px render limit"},
      {"tiles too small", 64, 256, 0, "at least 8 are needed (resolution >= 512)"},
      {"unknown layout", 0, 0, 9, "parameters.layout: unknown value 9"},
  };
  for (const Case& c : cases) {
    v1::BakeParameters in;
    in.set_frames(c.frames);
    in.set_resolution(c.resolution);
    in.set_layout(static_cast<v1::Layout>(c.layout));
    auto p = NormalizeParameters(in);
    ASSERT_FALSE(p.ok()) << c.name;
    EXPECT_EQ(p.status().code(), absl::StatusCode::kInvalidArgument) << c.name;
    EXPECT_NE(p.status().message().find(c.expect), std::string::npos) << c.name << ": " << p.status();
  }
}

TEST(BakeRequest, UnsafePathsAreRefused) {
  const char* bad[] = {"/etc/passwd", "../secret.bin", "a/../../b", "a//b", "./a", "a\\b", ""};
  for (const char* path : bad) {
    v1::MeshInput m = Gltf();
    m.mutable_files(0)->set_path(path);
    const absl::Status s = ValidateMeshInput(m);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << "path \"" << path << "\"";
    EXPECT_NE(s.message().find("mesh.files[0].path"), std::string::npos) << s;
  }
  v1::MeshInput dup = Gltf();
  *dup.add_files() = File("tree.bin", "again");
  EXPECT_NE(ValidateMeshInput(dup).message().find("name the same file"), std::string::npos);
  v1::MeshInput obj = Gltf();
  obj.mutable_entry()->set_path("tree.obj");
  EXPECT_NE(ValidateMeshInput(obj).message().find("neither a .glb nor a .gltf"), std::string::npos);
  v1::MeshInput bad_digest = Gltf();
  bad_digest.mutable_files(1)->mutable_digest()->set_hash("xyz");
  EXPECT_NE(ValidateMeshInput(bad_digest).message().find("mesh.files[1].digest.hash"), std::string::npos);
  EXPECT_TRUE(ValidateMeshInput(Gltf()).ok());
}

TEST(BakeRequest, CacheKeyDependsOnContentNotOnNamesOrOrder) {
  const v1::BakeParameters params = *NormalizeParameters({});
  const std::string key = ComputeCacheKey(Gltf(), params);
  EXPECT_EQ(key.size(), 64u);

  v1::MeshInput renamed = Gltf();
  renamed.mutable_entry()->set_path("copy_of_tree.gltf");
  EXPECT_EQ(ComputeCacheKey(renamed, params), key) << "entry file name must not matter";

  v1::MeshInput reordered = Gltf();
  reordered.mutable_files()->SwapElements(0, 1);
  EXPECT_EQ(ComputeCacheKey(reordered, params), key) << "file order must not matter";

  v1::MeshInput other_content = Gltf();
  *other_content.mutable_files(0) = File("tree.bin", "different binary");
  EXPECT_NE(ComputeCacheKey(other_content, params), key);

  v1::MeshInput moved = Gltf();
  moved.mutable_files(1)->set_path("tex/leaf.png");  // the .gltf refers to files by path
  EXPECT_NE(ComputeCacheKey(moved, params), key);

  v1::BakeParameters explicit_defaults;
  explicit_defaults.set_layout(v1::LAYOUT_OCTAHEDRAL);
  explicit_defaults.set_frames(12);
  explicit_defaults.set_resolution(2048);
  EXPECT_EQ(ComputeCacheKey(Gltf(), *NormalizeParameters(explicit_defaults)), key)
      << "explicit defaults must bake once with omitted ones";

  v1::BakeParameters hemi = params;
  hemi.set_layout(v1::LAYOUT_HEMI_OCTAHEDRAL);
  EXPECT_NE(ComputeCacheKey(Gltf(), hemi), key);
}

TEST(BakeRequest, CardDefaultsAreFilledInAndKeyed) {
  v1::BakeParameters in;
  in.set_product(v1::PRODUCT_CARDS);
  auto p = NormalizeParameters(in);
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(p->max_planes(), 8u);
  EXPECT_FLOAT_EQ(p->tolerance(), 0.05f);
  EXPECT_EQ(p->resolution(), 1024u);

  v1::BakeParameters explicit_defaults = in;
  explicit_defaults.set_max_planes(8);
  explicit_defaults.set_tolerance(0.05f);
  explicit_defaults.set_resolution(1024);
  const std::string key = ComputeCacheKey(Gltf(), *p);
  EXPECT_EQ(ComputeCacheKey(Gltf(), *NormalizeParameters(explicit_defaults)), key);
  v1::BakeParameters more = in;
  more.set_max_planes(9);
  EXPECT_NE(ComputeCacheKey(Gltf(), *NormalizeParameters(more)), key);
  v1::BakeParameters looser = in;
  looser.set_tolerance(0.0500001f);
  EXPECT_NE(ComputeCacheKey(Gltf(), *NormalizeParameters(looser)), key) << "tolerance keyed exactly";
  EXPECT_NE(ComputeCacheKey(Gltf(), *NormalizeParameters({})), key) << "cards and atlas never share a key";
  v1::BakeParameters hemi = in;
  hemi.set_layout(v1::LAYOUT_HEMI_OCTAHEDRAL);
  EXPECT_EQ(ComputeCacheKey(Gltf(), *NormalizeParameters(hemi)), key) << "cards have no views: layout ignored";
}

TEST(BakeRequest, BadCardParametersNameTheFieldAndLimit) {
  struct Case {
    const char* name;
    v1::Product product;
    std::optional<uint32_t> max_planes;
    std::optional<float> tolerance;
    uint32_t frames, resolution;
    int layout;
    const char* expect;
  } cases[] = {
      {"no planes", v1::PRODUCT_CARDS, 0u, {}, 0, 0, 0, "parameters.max_planes: 0 is out of range 1..64"},
      {"too many planes", v1::PRODUCT_CARDS, 65u, {}, 0, 0, 0, "parameters.max_planes: 65 is out of range 1..64"},
      {"zero tolerance", v1::PRODUCT_CARDS, {}, 0.0f, 0, 0, 0, "parameters.tolerance: 0 is out of range 0.0001..1"},
      {"huge tolerance", v1::PRODUCT_CARDS, {}, 2.0f, 0, 0, 0, "parameters.tolerance: 2 is out of range 0.0001..1"},
      {"nan tolerance", v1::PRODUCT_CARDS, {}, std::nanf(""), 0, 0, 0, "parameters.tolerance: nan is out of range"},
      {"tiny card atlas", v1::PRODUCT_CARDS, {}, {}, 0, 32, 0, "parameters.resolution: 32 is out of range 64..16384"},
      {"frames with cards", v1::PRODUCT_CARDS, {}, {}, 12, 0, 0, "parameters.frames: 12 given, but product "
                                                                 "PRODUCT_CARDS renders no views"},
      {"planes with atlas", v1::PRODUCT_ATLAS, 8u, {}, 0, 0, 0, "parameters.max_planes: only for product "
                                                                "PRODUCT_CARDS"},
      {"tolerance with surfels", v1::PRODUCT_SURFELS, {}, 0.1f, 0, 0, 0, "parameters.tolerance: only for product "
                                                                         "PRODUCT_CARDS"},
  };
  for (const Case& c : cases) {
    v1::BakeParameters in;
    in.set_product(c.product);
    if (c.max_planes) in.set_max_planes(*c.max_planes);
    if (c.tolerance) in.set_tolerance(*c.tolerance);
    in.set_frames(c.frames);
    in.set_resolution(c.resolution);
    in.set_layout(static_cast<v1::Layout>(c.layout));
    auto p = NormalizeParameters(in);
    ASSERT_FALSE(p.ok()) << c.name;
    EXPECT_EQ(p.status().code(), absl::StatusCode::kInvalidArgument) << c.name;
    EXPECT_NE(p.status().message().find(c.expect), std::string::npos) << c.name << ": " << p.status();
  }
}

TEST(BakeRequest, LodChainDefaultsAreFilledInAndKeyed) {
  v1::BakeParameters in;
  in.set_product(v1::PRODUCT_LOD_CHAIN);
  auto p = NormalizeParameters(in);
  ASSERT_TRUE(p.ok()) << p.status();
  ASSERT_EQ(p->lod_ratios_size(), 2);
  EXPECT_FLOAT_EQ(p->lod_ratios(0), 0.5f);
  EXPECT_FLOAT_EQ(p->lod_ratios(1), 0.1f);
  EXPECT_FLOAT_EQ(p->lod_pixel_error(), 1.0f);
  EXPECT_EQ(p->layout(), v1::LAYOUT_HEMI_OCTAHEDRAL) << "a LOD chain's impostor defaults to the hemisphere";

  // The explicit defaults bake once; other ratios or budgets do not.
  v1::BakeParameters explicit_in = in;
  explicit_in.add_lod_ratios(0.5f);
  explicit_in.add_lod_ratios(0.1f);
  explicit_in.set_lod_pixel_error(1.0f);
  explicit_in.set_layout(v1::LAYOUT_HEMI_OCTAHEDRAL);
  auto q = NormalizeParameters(explicit_in);
  ASSERT_TRUE(q.ok()) << q.status();
  v1::MeshInput mesh;
  mesh.mutable_entry()->set_path("m.glb");
  mesh.mutable_entry()->mutable_digest()->set_hash(std::string(64, 'a'));
  EXPECT_EQ(ComputeCacheKey(mesh, *p), ComputeCacheKey(mesh, *q));
  v1::BakeParameters other = *p;
  other.set_lod_ratios(1, 0.2f);
  EXPECT_NE(ComputeCacheKey(mesh, *p), ComputeCacheKey(mesh, other));
  other = *p;
  other.set_lod_pixel_error(2.0f);
  EXPECT_NE(ComputeCacheKey(mesh, *p), ComputeCacheKey(mesh, other));
  v1::BakeParameters atlas;
  atlas.set_layout(v1::LAYOUT_HEMI_OCTAHEDRAL);
  auto a = NormalizeParameters(atlas);
  ASSERT_TRUE(a.ok());
  EXPECT_NE(ComputeCacheKey(mesh, *p), ComputeCacheKey(mesh, *a));
}

TEST(BakeRequest, BadLodParametersNameTheFieldAndRule) {
  struct Case {
    const char* name;
    v1::Product product;
    std::vector<float> ratios;
    std::optional<float> pixel_error;
    const char* expect;
  };
  const Case cases[] = {
      {"increasing", v1::PRODUCT_LOD_CHAIN, {0.1f, 0.5f}, {},
       "parameters.lod_ratios[1]: 0.5 must be smaller than parameters.lod_ratios[0] (0.100000001); ratios must be "
       "strictly decreasing"},
      {"repeated", v1::PRODUCT_LOD_CHAIN, {0.5f, 0.5f}, {}, "parameters.lod_ratios[1]: 0.5 must be smaller"},
      {"one", v1::PRODUCT_LOD_CHAIN, {1.0f}, {}, "parameters.lod_ratios[0]: 1 is outside the open range (0, 1)"},
      {"zero", v1::PRODUCT_LOD_CHAIN, {0.5f, 0.0f}, {}, "parameters.lod_ratios[1]: 0 is outside the open range (0, 1)"},
      {"negative", v1::PRODUCT_LOD_CHAIN, {-0.5f}, {}, "parameters.lod_ratios[0]: -0.5 is outside the open range"},
      {"nan", v1::PRODUCT_LOD_CHAIN, {std::nanf("")}, {}, "parameters.lod_ratios[0]: nan is outside the open range"},
      {"too many", v1::PRODUCT_LOD_CHAIN, {0.9f, 0.8f, 0.7f, 0.6f, 0.5f, 0.4f, 0.3f, 0.2f, 0.1f}, {},
       "parameters.lod_ratios: 9 levels is more than the limit of 8"},
      {"tiny budget", v1::PRODUCT_LOD_CHAIN, {}, 0.05f, "parameters.lod_pixel_error: 0.0500000007 is out of range 0.1..16"},
      {"huge budget", v1::PRODUCT_LOD_CHAIN, {}, 17.0f, "parameters.lod_pixel_error: 17 is out of range 0.1..16"},
      {"ratios with atlas", v1::PRODUCT_ATLAS, {0.5f}, {}, "parameters.lod_ratios: only for product PRODUCT_LOD_CHAIN"},
      {"budget with surfels", v1::PRODUCT_SURFELS, {}, 1.0f,
       "parameters.lod_pixel_error: only for product PRODUCT_LOD_CHAIN"},
  };
  for (const Case& c : cases) {
    v1::BakeParameters in;
    in.set_product(c.product);
    for (float r : c.ratios) in.add_lod_ratios(r);
    if (c.pixel_error) in.set_lod_pixel_error(*c.pixel_error);
    auto p = NormalizeParameters(in);
    ASSERT_FALSE(p.ok()) << c.name;
    EXPECT_EQ(p.status().code(), absl::StatusCode::kInvalidArgument) << c.name;
    EXPECT_NE(p.status().message().find(c.expect), std::string::npos) << c.name << ": " << p.status();
  }
}

}  // namespace
}  // namespace impostor
