// LoadGltfScene on real assets from the shared asset folder.
#include "worker/scene/gltf_loader.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <glm/geometric.hpp>
#include <string>

#include "tests/scene/test_assets.h"
#include "worker/scene/bounding_sphere.h"

namespace impostor {
namespace {

using testing::Asset;
namespace fs = std::filesystem;

#define SKIP_IF_MISSING(path) \
  if (!fs::exists(path)) GTEST_SKIP() << "asset not available: " << (path)

Scene LoadOrDie(const fs::path& path, const GltfLoadLimits& limits = {}) {
  absl::StatusOr<Scene> scene = LoadGltfScene(path, limits);
  EXPECT_TRUE(scene.ok()) << path << ": " << scene.status();
  return scene.ok() ? *std::move(scene) : Scene{};
}

// Invariants every loaded scene must satisfy, whatever the asset.
void ExpectWellFormed(const Scene& scene) {
  ASSERT_FALSE(scene.indices.empty());
  ASSERT_EQ(scene.indices.size() % 3, 0u);
  ASSERT_FALSE(scene.materials.empty());
  uint32_t covered = 0;
  for (const SceneBatch& b : scene.batches) {
    EXPECT_EQ(b.first_index, covered);
    EXPECT_EQ(b.index_count % 3, 0u);
    EXPECT_GE(b.material, 0);
    EXPECT_LT(b.material, static_cast<int>(scene.materials.size()));
    covered += b.index_count;
  }
  EXPECT_EQ(covered, scene.indices.size());
  for (uint32_t i : scene.indices) ASSERT_LT(i, scene.vertices.size());
  for (const SceneMaterial& m : scene.materials) {
    for (int t : {m.base_color_texture, m.metallic_roughness_texture, m.normal_texture,
                  m.occlusion_texture}) {
      EXPECT_GE(t, -1);
      EXPECT_LT(t, static_cast<int>(scene.textures.size()));
    }
  }
  for (const SceneTexture& t : scene.textures) {
    EXPECT_GT(t.width, 0);
    EXPECT_GT(t.height, 0);
    EXPECT_EQ(t.rgba8.size(), static_cast<size_t>(t.width) * t.height * 4);
  }
  for (const SceneVertex& v : scene.vertices) {
    ASSERT_NEAR(glm::length(v.normal), 1.0f, 1e-3f);
    ASSERT_NEAR(glm::length(glm::vec3(v.tangent)), 1.0f, 1e-3f);
    ASSERT_TRUE(v.tangent.w == 1.0f || v.tangent.w == -1.0f);
    ASSERT_TRUE(glm::all(glm::lessThanEqual(scene.bounds_min, v.position)));
    ASSERT_TRUE(glm::all(glm::lessThanEqual(v.position, scene.bounds_max)));
  }
}

double MillisToLoad(const fs::path& path, Scene* out) {
  const auto start = std::chrono::steady_clock::now();
  *out = LoadOrDie(path);
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

TEST(GltfLoaderTest, DamagedHelmetGlb) {
  const fs::path path = Asset("props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb");
  SKIP_IF_MISSING(path);
  Scene scene;
  const double ms = MillisToLoad(path, &scene);
  std::printf("[ timing ] DamagedHelmet.glb loaded in %.1f ms\n", ms);
  ExpectWellFormed(scene);
  EXPECT_EQ(scene.TriangleCount(), 15452u);
  ASSERT_EQ(scene.materials.size(), 1u);
  const SceneMaterial& m = scene.materials[0];
  // baseColor, metalRough, normal, occlusion and emissive are decoded.
  EXPECT_EQ(scene.textures.size(), 5u);
  ASSERT_GE(m.emissive_texture, 0);
  EXPECT_TRUE(scene.textures[m.emissive_texture].srgb);
  ASSERT_GE(m.base_color_texture, 0);
  ASSERT_GE(m.metallic_roughness_texture, 0);
  ASSERT_GE(m.normal_texture, 0);
  ASSERT_GE(m.occlusion_texture, 0);
  EXPECT_TRUE(scene.textures[m.base_color_texture].srgb);
  EXPECT_FALSE(scene.textures[m.normal_texture].srgb);
  EXPECT_FALSE(scene.textures[m.metallic_roughness_texture].srgb);
  for (const SceneTexture& t : scene.textures) {
    EXPECT_EQ(t.width, 2048) << t.name;
    EXPECT_EQ(t.height, 2048) << t.name;
  }
  // The helmet is about 2 units across, centred near the origin.
  const glm::vec3 size = scene.bounds_max - scene.bounds_min;
  EXPECT_GT(size.x, 1.0f);
  EXPECT_LT(size.x, 4.0f);
}

TEST(GltfLoaderTest, WaterBottleWithExternalFiles) {
  const fs::path path = Asset("props_pbr/WaterBottle/glTF/WaterBottle.gltf");
  SKIP_IF_MISSING(path);
  const Scene scene = LoadOrDie(path);
  ExpectWellFormed(scene);
  EXPECT_EQ(scene.TriangleCount(), 4510u);
  ASSERT_EQ(scene.materials.size(), 1u);
  const SceneMaterial& m = scene.materials[0];
  ASSERT_GE(m.base_color_texture, 0);
  ASSERT_GE(m.normal_texture, 0);
  // The ORM image serves both metallicRoughness and occlusion: one texture.
  EXPECT_EQ(m.metallic_roughness_texture, m.occlusion_texture);
  // + the emissive map.
  EXPECT_EQ(scene.textures.size(), 4u);
  for (const SceneTexture& t : scene.textures) {
    EXPECT_EQ(t.width, 2048) << t.name;
    EXPECT_EQ(t.height, 2048) << t.name;
  }
}

TEST(GltfLoaderTest, TreeNestedMatricesAndScale) {
  const fs::path path = Asset("vegetation/TreeLowPoly_RicardoSanchez/scene.gltf");
  SKIP_IF_MISSING(path);
  const Scene scene = LoadOrDie(path);
  ExpectWellFormed(scene);
  EXPECT_EQ(scene.TriangleCount(), 778u);
  // The mesh is 24.7 units tall along its local Z; the nested matrices
  // scale it by 100 and rotate Z-up to Y-up, so it stands ~2470 units tall
  // on Y (the FBX export was in centimetres), base at y = 0.
  const glm::vec3 size = scene.bounds_max - scene.bounds_min;
  std::printf("[ info   ] tree bounds (%g %g %g) .. (%g %g %g)\n", scene.bounds_min.x,
              scene.bounds_min.y, scene.bounds_min.z, scene.bounds_max.x, scene.bounds_max.y,
              scene.bounds_max.z);
  EXPECT_GT(size.y, size.x);
  EXPECT_GT(size.y, size.z);
  EXPECT_NEAR(size.y, 2470.5f, 0.5f);
  EXPECT_NEAR(scene.bounds_min.y, 0.0f, 0.01f);
  EXPECT_NEAR(scene.bounds_min.x, -842.15f, 0.05f);
  EXPECT_NEAR(scene.bounds_max.x, 910.26f, 0.05f);
  // Leaves: the BLEND material with an RGBA PNG.
  bool has_blend = false;
  for (const SceneMaterial& m : scene.materials) has_blend |= m.alpha_mode == AlphaMode::kBlend;
  EXPECT_TRUE(has_blend);
  const fs::path masked = Asset("vegetation/TreeLowPoly_RicardoSanchez/scene_alphaMASK.gltf");
  const Scene mask_scene = LoadOrDie(masked);
  bool has_mask = false;
  for (const SceneMaterial& m : mask_scene.materials) {
    if (m.alpha_mode == AlphaMode::kMask) {
      has_mask = true;
      EXPECT_FLOAT_EQ(m.alpha_cutoff, 0.5f);
    }
  }
  EXPECT_TRUE(has_mask);
}

TEST(GltfLoaderTest, FoxNonIndexedSkinnedInBindPose) {
  const fs::path path = Asset("props_pbr/Fox/glTF-Binary/Fox.glb");
  SKIP_IF_MISSING(path);
  const Scene scene = LoadOrDie(path);
  ExpectWellFormed(scene);
  EXPECT_EQ(scene.TriangleCount(), 576u);
  EXPECT_EQ(scene.vertices.size(), 576u * 3);  // non-indexed: one vertex per corner
}

TEST(GltfLoaderTest, BoxGlbEmbeddedAndSpacesInNames) {
  for (const char* rel :
       {"props_pbr/Box/glTF-Binary/Box.glb", "props_pbr/Box/glTF-Embedded/Box.gltf",
        "edge_cases/khronos/Box With Spaces/glTF/Box With Spaces.gltf",
        "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb"}) {
    SCOPED_TRACE(rel);
    const fs::path path = Asset(rel);
    if (!fs::exists(path)) continue;
    const Scene scene = LoadOrDie(path);
    ExpectWellFormed(scene);
    EXPECT_EQ(scene.TriangleCount(), 12u);
  }
}

TEST(GltfLoaderTest, UnicodeFileNames) {
  const fs::path path = Asset("edge_cases/khronos/Unicode❤♻Test/glTF/Unicode❤♻Test.gltf");
  SKIP_IF_MISSING(path);
  const Scene scene = LoadOrDie(path);
  ExpectWellFormed(scene);
  EXPECT_EQ(scene.TriangleCount(), 2u);
  EXPECT_EQ(scene.textures.size(), 1u);
}

TEST(GltfLoaderTest, PrimitiveModesStripsAndFansBecomeLists) {
  const fs::path path = Asset("edge_cases/khronos/MeshPrimitiveModes/glTF/MeshPrimitiveModes.gltf");
  SKIP_IF_MISSING(path);
  const Scene scene = LoadOrDie(path);
  ExpectWellFormed(scene);
  // TRIANGLES (18 indices: 6) + TRIANGLE_STRIP (6: 4) + TRIANGLE_FAN (8: 6);
  // the POINTS/LINES/LINE_LOOP/LINE_STRIP meshes are skipped.
  EXPECT_EQ(scene.TriangleCount(), 16u);
  EXPECT_EQ(scene.batches.size(), 3u);
}

TEST(GltfLoaderTest, NegativeScaleFlipsWinding) {
  const fs::path path =
      Asset("edge_cases/khronos/NegativeScaleTest/glTF-Binary/NegativeScaleTest.glb");
  SKIP_IF_MISSING(path);
  const Scene scene = LoadOrDie(path);
  ExpectWellFormed(scene);
  EXPECT_EQ(scene.TriangleCount(), 7724u);  // "as drawn"
  int flipped = 0;
  for (const SceneBatch& b : scene.batches) flipped += b.flipped_winding;
  EXPECT_GT(flipped, 0);
  EXPECT_LT(flipped, static_cast<int>(scene.batches.size()));
}

TEST(GltfLoaderTest, GpuInstancing) {
  const fs::path path =
      Asset("edge_cases/khronos/SimpleInstancing/glTF-Binary/SimpleInstancing.glb");
  SKIP_IF_MISSING(path);
  const Scene scene = LoadOrDie(path);
  ExpectWellFormed(scene);
  EXPECT_EQ(scene.TriangleCount(), 1500u);  // 12 x 125 instances
}

TEST(GltfLoaderTest, SparseAccessorIsApplied) {
  const fs::path path =
      Asset("edge_cases/khronos/SimpleSparseAccessor/glTF/SimpleSparseAccessor.gltf");
  SKIP_IF_MISSING(path);
  const Scene scene = LoadOrDie(path);
  ExpectWellFormed(scene);
  EXPECT_EQ(scene.TriangleCount(), 12u);
  // The dense grid has y in 0..1; the sparse values move vertices 8, 10
  // and 12 to (1,2), (3,3) and (5,4).
  EXPECT_FLOAT_EQ(scene.bounds_max.y, 4.0f);
  bool moved = false;
  for (const SceneVertex& v : scene.vertices) moved |= v.position == glm::vec3(3, 3, 0);
  EXPECT_TRUE(moved);
}

TEST(GltfLoaderTest, QuantizedDuckMatchesFloatDuck) {
  const fs::path quantized = Asset("props_pbr/Duck/glTF-Quantized/Duck.gltf");
  const fs::path plain = Asset("props_pbr/Duck/glTF-Binary/Duck.glb");
  SKIP_IF_MISSING(quantized);
  const Scene a = LoadOrDie(quantized);
  const Scene b = LoadOrDie(plain);
  ExpectWellFormed(a);
  EXPECT_EQ(a.TriangleCount(), 4212u);
  EXPECT_EQ(b.TriangleCount(), 4212u);
  const float extent = glm::length(b.bounds_max - b.bounds_min);
  EXPECT_LT(glm::length(a.bounds_min - b.bounds_min), 0.01f * extent);
  EXPECT_LT(glm::length(a.bounds_max - b.bounds_max), 0.01f * extent);
}

TEST(GltfLoaderTest, NoUvsAndFactorOnlyMaterials) {
  const fs::path path = Asset("vegetation/Quaternius_CommonTree_1/CommonTree_1.glb");
  SKIP_IF_MISSING(path);
  const Scene scene = LoadOrDie(path);
  ExpectWellFormed(scene);
  EXPECT_EQ(scene.TriangleCount(), 2888u);
  EXPECT_TRUE(scene.textures.empty());
  for (const SceneVertex& v : scene.vertices) ASSERT_EQ(v.uv, glm::vec2(0.0f));
}

TEST(GltfLoaderTest, PrimitiveWithoutMaterialGetsTheGltfDefault) {
  const fs::path path =
      Asset("edge_cases/khronos/TriangleWithoutIndices/glTF/TriangleWithoutIndices.gltf");
  SKIP_IF_MISSING(path);
  const Scene scene = LoadOrDie(path);
  ExpectWellFormed(scene);
  EXPECT_EQ(scene.TriangleCount(), 1u);
  ASSERT_EQ(scene.materials.size(), 1u);
  EXPECT_EQ(scene.materials[0].base_color_factor, glm::vec4(1.0f));
  EXPECT_EQ(scene.materials[0].metallic_factor, 1.0f);
  EXPECT_EQ(scene.materials[0].roughness_factor, 1.0f);
  // No NORMAL in the file: generated from the triangle (it lies in z = 0).
  EXPECT_NEAR(std::abs(scene.vertices[0].normal.z), 1.0f, 1e-5f);
}

TEST(GltfLoaderTest, TransmissionTestHighPoly) {
  const fs::path path = Asset("highpoly/TransmissionTest/glTF-Binary/TransmissionTest.glb");
  SKIP_IF_MISSING(path);
  Scene scene;
  const double ms = MillisToLoad(path, &scene);
  std::printf("[ timing ] TransmissionTest.glb loaded in %.1f ms\n", ms);
  ExpectWellFormed(scene);
  EXPECT_EQ(scene.TriangleCount(), 128775u);
}

TEST(GltfLoaderTest, MillionTrianglesFromSharedAccessors) {
  const fs::path path =
      Asset("highpoly/MetalRoughSpheresNoTextures/glTF-Binary/MetalRoughSpheresNoTextures.glb");
  SKIP_IF_MISSING(path);
  Scene scene;
  const double ms = MillisToLoad(path, &scene);
  std::printf("[ timing ] MetalRoughSpheresNoTextures.glb loaded in %.1f ms\n", ms);
  EXPECT_EQ(scene.TriangleCount(), 1040409u);
  const BoundingSphere sphere = ComputeBoundingSphere(scene);
  for (const SceneVertex& v : scene.vertices) {
    ASSERT_LE(glm::length(v.position - sphere.center), sphere.radius * (1 + 1e-6f));
  }
}

TEST(GltfLoaderTest, LoadingIsDeterministic) {
  const fs::path path = Asset("props_pbr/Duck/glTF-Binary/Duck.glb");
  SKIP_IF_MISSING(path);
  const Scene a = LoadOrDie(path);
  const Scene b = LoadOrDie(path);
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  EXPECT_EQ(0, std::memcmp(a.vertices.data(), b.vertices.data(),
                           a.vertices.size() * sizeof(SceneVertex)));
  EXPECT_EQ(a.indices, b.indices);
  ASSERT_EQ(a.textures.size(), b.textures.size());
  EXPECT_EQ(a.textures[0].rgba8, b.textures[0].rgba8);
}

TEST(GltfLoaderTest, GeneratedTangentsFollowTheUvs) {
  // DamagedHelmet has a normal map and no TANGENT: tangents are generated.
  // For every triangle, the tangent must point roughly along dP/du.
  const fs::path path = Asset("props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb");
  SKIP_IF_MISSING(path);
  const Scene scene = LoadOrDie(path);
  int agree = 0, total = 0;
  for (size_t t = 0; t + 2 < scene.indices.size(); t += 3) {
    const SceneVertex& a = scene.vertices[scene.indices[t]];
    const SceneVertex& b = scene.vertices[scene.indices[t + 1]];
    const SceneVertex& c = scene.vertices[scene.indices[t + 2]];
    const glm::vec2 d1 = b.uv - a.uv, d2 = c.uv - a.uv;
    const float det = d1.x * d2.y - d2.x * d1.y;
    if (std::abs(det) < 1e-8f) continue;
    const glm::vec3 dpdu =
        ((b.position - a.position) * d2.y - (c.position - a.position) * d1.y) / det;
    if (glm::length(dpdu) == 0.0f) continue;
    ++total;
    agree += glm::dot(glm::normalize(dpdu), glm::vec3(a.tangent)) > 0.5f;
  }
  EXPECT_GT(agree, total * 9 / 10);
}

TEST(GltfLoaderTest, LimitsAreEnforced) {
  const fs::path path = Asset("props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb");
  SKIP_IF_MISSING(path);
  struct Case {
    const char* name;
    GltfLoadLimits limits;
    absl::StatusCode code;
    const char* needle;
  };
  GltfLoadLimits triangles, dimension, bytes, bad;
  triangles.max_triangles = 1000;
  dimension.max_texture_dimension = 1024;
  bytes.max_texture_bytes = 20u << 20;  // one 2048^2 texture is 16 MiB
  bad.max_node_depth = 0;
  const Case cases[] = {
      {"triangles", triangles, absl::StatusCode::kResourceExhausted, "max_triangles = 1000"},
      {"dimension", dimension, absl::StatusCode::kResourceExhausted,
       "max_texture_dimension = 1024"},
      {"bytes", bytes, absl::StatusCode::kResourceExhausted, "max_texture_bytes"},
      {"bad limits", bad, absl::StatusCode::kInvalidArgument, "max_node_depth 0"},
  };
  for (const Case& c : cases) {
    const absl::StatusOr<Scene> scene = LoadGltfScene(path, c.limits);
    EXPECT_EQ(scene.status().code(), c.code) << c.name << ": " << scene.status();
    EXPECT_NE(std::string(scene.status().message()).find(c.needle), std::string::npos)
        << c.name << ": " << scene.status();
  }
}

TEST(GltfLoaderTest, NodeDepthLimit) {
  const fs::path path = Asset("vegetation/TreeLowPoly_RicardoSanchez/scene.gltf");
  SKIP_IF_MISSING(path);
  GltfLoadLimits limits;
  limits.max_node_depth = 1;
  const absl::StatusOr<Scene> scene = LoadGltfScene(path, limits);
  EXPECT_EQ(scene.status().code(), absl::StatusCode::kInvalidArgument) << scene.status();
  EXPECT_NE(std::string(scene.status().message()).find("max_node_depth = 1"), std::string::npos)
      << scene.status();
}

// Every curated model outside the validator corpus either loads or fails
// for a reason this test knows about.
TEST(GltfLoaderTest, EveryCuratedAssetLoadsOrFailsForAKnownReason) {
  if (!fs::exists(testing::AssetsDir())) GTEST_SKIP() << "no assets";
  int loaded = 0;
  for (const auto& entry : fs::recursive_directory_iterator(testing::AssetsDir())) {
    const fs::path& p = entry.path();
    if (p.string().find("gltf-validator-tests") != std::string::npos) continue;
    if (p.extension() != ".gltf" && p.extension() != ".glb") continue;
    const absl::StatusOr<Scene> scene = LoadGltfScene(p);
    const std::string rel = fs::relative(p, testing::AssetsDir()).string();
    if (scene.ok()) {
      ++loaded;
      SCOPED_TRACE(rel);
      ExpectWellFormed(*scene);
      continue;
    }
    const std::string message(scene.status().message());
    std::printf("[ info   ] %s: %s\n", rel.c_str(), message.c_str());
    const bool known =
        message.find("KHR_draco_mesh_compression is not supported") != std::string::npos ||
        message.find("refers to missing file") != std::string::npos;
    EXPECT_TRUE(known) << rel << ": " << scene.status();
  }
  EXPECT_GT(loaded, 25);
}

}  // namespace
}  // namespace impostor
