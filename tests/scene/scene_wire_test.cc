// scene_wire.h: a scene survives the trip through bytes exactly, and bytes
// that break any invariant the bake relies on are refused with DATA_LOSS
// naming what broke, never a crash or an allocation the bytes did not pay
// for (they come from a child that decoded untrusted input).
#include "worker/scene/scene_wire.h"

#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <string>

#include "tests/scene/test_assets.h"
#include "worker/scene/gltf_loader.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

std::span<const uint8_t> Bytes(const std::string& s) {
  return {reinterpret_cast<const uint8_t*>(s.data()), s.size()};
}

// Field by field, so a field the format forgot shows up by name.
void ExpectSameScene(const Scene& a, const Scene& b) {
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  EXPECT_EQ(std::memcmp(a.vertices.data(), b.vertices.data(), a.vertices.size() * sizeof(SceneVertex)), 0);
  EXPECT_EQ(a.indices, b.indices);
  ASSERT_EQ(a.batches.size(), b.batches.size());
  for (size_t i = 0; i < a.batches.size(); ++i) {
    EXPECT_EQ(a.batches[i].first_index, b.batches[i].first_index);
    EXPECT_EQ(a.batches[i].index_count, b.batches[i].index_count);
    EXPECT_EQ(a.batches[i].material, b.batches[i].material);
    EXPECT_EQ(a.batches[i].flipped_winding, b.batches[i].flipped_winding);
  }
  ASSERT_EQ(a.materials.size(), b.materials.size());
  for (size_t i = 0; i < a.materials.size(); ++i) {
    const SceneMaterial& x = a.materials[i];
    const SceneMaterial& y = b.materials[i];
    EXPECT_EQ(x.base_color_factor, y.base_color_factor);
    EXPECT_EQ(x.base_color_texture, y.base_color_texture);
    EXPECT_EQ(x.metallic_factor, y.metallic_factor);
    EXPECT_EQ(x.roughness_factor, y.roughness_factor);
    EXPECT_EQ(x.metallic_roughness_texture, y.metallic_roughness_texture);
    EXPECT_EQ(x.normal_texture, y.normal_texture);
    EXPECT_EQ(x.normal_scale, y.normal_scale);
    EXPECT_EQ(x.occlusion_texture, y.occlusion_texture);
    EXPECT_EQ(x.occlusion_strength, y.occlusion_strength);
    EXPECT_EQ(x.alpha_mode, y.alpha_mode);
    EXPECT_EQ(x.alpha_cutoff, y.alpha_cutoff);
    EXPECT_EQ(x.double_sided, y.double_sided);
    EXPECT_EQ(x.emissive_factor, y.emissive_factor);
    EXPECT_EQ(x.emissive_texture, y.emissive_texture);
    EXPECT_EQ(x.emissive_strength, y.emissive_strength);
    for (int s = 0; s < kTextureSlotCount; ++s) {
      EXPECT_EQ(x.uv[s].tex_coord, y.uv[s].tex_coord);
      EXPECT_EQ(x.uv[s].transform, y.uv[s].transform);
    }
    EXPECT_EQ(x.name, y.name);
  }
  ASSERT_EQ(a.textures.size(), b.textures.size());
  for (size_t i = 0; i < a.textures.size(); ++i) {
    const SceneTexture& x = a.textures[i];
    const SceneTexture& y = b.textures[i];
    EXPECT_EQ(x.width, y.width);
    EXPECT_EQ(x.height, y.height);
    EXPECT_TRUE(x.rgba8 == y.rgba8) << "texture " << i;
    EXPECT_EQ(x.srgb, y.srgb);
    EXPECT_EQ(x.has_alpha_channel, y.has_alpha_channel);
    EXPECT_EQ(x.wrap_s, y.wrap_s);
    EXPECT_EQ(x.wrap_t, y.wrap_t);
    EXPECT_EQ(x.name, y.name);
  }
  EXPECT_EQ(a.bounds_min, b.bounds_min);
  EXPECT_EQ(a.bounds_max, b.bounds_max);
  EXPECT_EQ(a.warnings, b.warnings);
}

// A small scene with every part present: two triangles, two materials,
// one 2x1 texture, a warning.
Scene SmallScene() {
  Scene s;
  s.vertices.resize(4);
  for (int i = 0; i < 4; ++i) s.vertices[i].position = glm::vec3(i, i % 2, 0);
  s.indices = {0, 1, 2, 1, 3, 2};
  s.materials.resize(2);
  s.materials[1].base_color_texture = 0;
  s.materials[1].alpha_mode = AlphaMode::kMask;
  s.materials[1].name = "leaf";
  s.textures.push_back({.width = 2, .height = 1, .rgba8 = {1, 2, 3, 4, 5, 6, 7, 8}, .srgb = true, .name = "t"});
  s.batches = {{.first_index = 0, .index_count = 3, .material = 0},
               {.first_index = 3, .index_count = 3, .material = 1, .flipped_winding = true}};
  s.bounds_max = glm::vec3(3, 1, 0);
  s.warnings = {"skipped 1 point primitive"};
  return s;
}

TEST(SceneWireTest, ARealAssetComesBackExactly) {
  const fs::path path = testing::Asset("props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb");
  if (!fs::exists(path)) GTEST_SKIP() << "no assets";
  absl::StatusOr<Scene> scene = LoadGltfScene(path, {});
  ASSERT_TRUE(scene.ok()) << scene.status();
  std::string bytes;
  EncodeScene(*scene, &bytes);
  absl::StatusOr<Scene> back = DecodeScene(Bytes(bytes));
  ASSERT_TRUE(back.ok()) << back.status();
  ExpectSameScene(*scene, *back);
  EXPECT_GT(back->textures.size(), 0u);
}

TEST(SceneWireTest, EveryTruncationIsRefused) {
  std::string bytes;
  EncodeScene(SmallScene(), &bytes);
  ASSERT_TRUE(DecodeScene(Bytes(bytes)).ok());
  for (size_t n = 0; n < bytes.size(); ++n) {
    const absl::StatusOr<Scene> s = DecodeScene(Bytes(bytes.substr(0, n)));
    ASSERT_EQ(s.status().code(), absl::StatusCode::kDataLoss) << "prefix of " << n << " bytes";
  }
  bytes.push_back('x');
  EXPECT_NE(DecodeScene(Bytes(bytes)).status().message().find("1 bytes after the scene"), std::string::npos);
}

// Each case breaks one invariant of a valid scene; the message names it.
TEST(SceneWireTest, BrokenInvariantsAreNamed) {
  struct Case {
    const char* needle;
    void (*breaks)(Scene&);
  };
  const Case cases[] = {
      {"index 4 = 9 out of range (4 vertices)", [](Scene& s) { s.indices[4] = 9; }},
      {"5 indices are not whole triangles", [](Scene& s) { s.indices.pop_back(); }},
      {"batch 1 indices [3, +6) are not whole triangles", [](Scene& s) { s.batches[1].index_count = 6; }},
      {"batch 0 material 2 out of range (2 materials)", [](Scene& s) { s.batches[0].material = 2; }},
      {"material 1 base colour texture 1 out of range (1 textures)",
       [](Scene& s) { s.materials[1].base_color_texture = 1; }},
      {"material 0 normal texture -2 out of range", [](Scene& s) { s.materials[0].normal_texture = -2; }},
      {"material 1 emissive texture 3 out of range", [](Scene& s) { s.materials[1].emissive_texture = 3; }},
      {"material 0 alpha mode 7 is unknown", [](Scene& s) { s.materials[0].alpha_mode = AlphaMode{7}; }},
      {"is 3x1 with 8 bytes of RGBA8", [](Scene& s) { s.textures[0].width = 3; }},
      {"is 0x1 with 0 bytes of RGBA8", [](Scene& s) { s.textures[0].width = 0; s.textures[0].rgba8.clear(); }},
      {"scene has no materials", [](Scene& s) { s.materials.clear(); }},
      {"empty scene (4 vertices, 0 indices, 0 batches)", [](Scene& s) { s.indices.clear(); s.batches.clear(); }},
  };
  for (const Case& c : cases) {
    Scene scene = SmallScene();
    c.breaks(scene);
    std::string bytes;
    EncodeScene(scene, &bytes);
    const absl::StatusOr<Scene> s = DecodeScene(Bytes(bytes));
    EXPECT_EQ(s.status().code(), absl::StatusCode::kDataLoss) << c.needle;
    EXPECT_NE(s.status().message().find(c.needle), std::string::npos) << c.needle << ": " << s.status();
  }
}

// A forged count (the vertex count, the first field after the magic) that
// promises far more than the bytes hold is refused before any allocation.
TEST(SceneWireTest, ACountPastTheEndAllocatesNothing) {
  std::string bytes;
  EncodeScene(SmallScene(), &bytes);
  const uint64_t forged = std::numeric_limits<uint64_t>::max() / 8;
  std::memcpy(bytes.data() + 8, &forged, sizeof(forged));
  const absl::StatusOr<Scene> s = DecodeScene(Bytes(bytes));
  EXPECT_EQ(s.status().code(), absl::StatusCode::kDataLoss);
  EXPECT_NE(s.status().message().find("vertices count"), std::string::npos) << s.status();
  EXPECT_EQ(DecodeScene(Bytes("not a scene at all")).status().code(), absl::StatusCode::kDataLoss);
}

}  // namespace
}  // namespace impostor
