// Loader facts for the glTF features that change what a frame looks like,
// and the clear answers for what cannot be baked: warnings that travel with
// the scene, refused required extensions, missing texture files, points and
// lines, per-slot UV sets and transforms, vertex colours, morph targets at
// their default weights, skinned meshes in bind pose, generated tangents.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <glm/geometric.hpp>
#include <string>
#include <vector>

#include "tests/scene/test_assets.h"
#include "worker/scene/gltf_loader.h"
#include "worker/scene/scene.h"
#include "worker/scene/tangent_space.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::Asset;
using testing::Base64;
using testing::MakePng;
using testing::TriangleGltf;
using testing::TriangleOptions;

#define SKIP_IF_MISSING(path) \
  if (!fs::exists(path)) GTEST_SKIP() << "asset missing: " << (path)

bool HasWarning(const Scene& scene, const std::string& needle) {
  for (const std::string& w : scene.warnings) {
    if (w.find(needle) != std::string::npos) return true;
  }
  return false;
}

std::string AllWarnings(const Scene& scene) {
  std::string out;
  for (const std::string& w : scene.warnings) out += w + " | ";
  return out;
}

absl::StatusOr<Scene> FromText(const std::string& gltf) {
  return LoadGltfSceneFromMemory(gltf, "test.gltf");
}

TEST(GltfFeaturesTest, MeshPrimitiveModesDrawsTrianglesAndWarnsAboutPointsAndLines) {
  const fs::path path = Asset("edge_cases/khronos/MeshPrimitiveModes/glTF/MeshPrimitiveModes.gltf");
  SKIP_IF_MISSING(path);
  absl::StatusOr<Scene> scene = LoadGltfScene(path);
  ASSERT_TRUE(scene.ok()) << scene.status();
  // TRIANGLES, TRIANGLE_STRIP and TRIANGLE_FAN meshes: three batches.
  EXPECT_EQ(scene->batches.size(), 3u);
  EXPECT_GT(scene->TriangleCount(), 0u);
  ASSERT_EQ(scene->warnings.size(), 1u) << AllWarnings(*scene);
  const std::string& w = scene->warnings[0];
  EXPECT_NE(w.find("points/lines primitives skipped"), std::string::npos) << w;
  for (const char* mesh : {"mesh with POINTS", "mesh with LINES", "mesh with LINE_LOOP",
                           "mesh with LINE_STRIP"}) {
    EXPECT_NE(w.find(mesh), std::string::npos) << mesh << " not named in: " << w;
  }
  // Each by glTF's name of its mode.
  for (const char* mode : {"mode 0 POINTS", "mode 1 LINES", "mode 2 LINE_LOOP", "mode 3 LINE_STRIP"}) {
    EXPECT_NE(w.find(mode), std::string::npos) << mode << " not named in: " << w;
  }
}

TEST(GltfFeaturesTest, OnlyPointsIsRefusedNamingTheMesh) {
  TriangleOptions o;
  o.primitive_extra = R"(, "mode": 0)";
  absl::StatusOr<Scene> scene = FromText(TriangleGltf(o));
  ASSERT_EQ(scene.status().code(), absl::StatusCode::kInvalidArgument) << scene.status();
  EXPECT_NE(scene.status().message().find("mesh 0"), std::string::npos) << scene.status();
  EXPECT_NE(scene.status().message().find("POINTS"), std::string::npos) << scene.status();
}

TEST(GltfFeaturesTest, UnsupportedRequiredExtensionsAreRefusedByName) {
  for (const char* ext : {"KHR_draco_mesh_compression", "EXT_meshopt_compression",
                          "KHR_texture_basisu", "KHR_meshopt_compression"}) {
    TriangleOptions o;
    o.extra_top_level = std::string(R"("extensionsUsed": [")") + ext +
                        R"("], "extensionsRequired": [")" + ext + R"("],)";
    absl::StatusOr<Scene> scene = FromText(TriangleGltf(o));
    ASSERT_EQ(scene.status().code(), absl::StatusCode::kInvalidArgument) << ext;
    EXPECT_NE(scene.status().message().find(ext), std::string::npos) << scene.status();
  }
  // Used but not required: the file has a fallback, so it loads.
  TriangleOptions o;
  o.extra_top_level = R"("extensionsUsed": ["KHR_draco_mesh_compression"],)";
  EXPECT_TRUE(FromText(TriangleGltf(o)).ok());
}

TEST(GltfFeaturesTest, MissingTextureFileIsAnErrorNamingTheFile) {
  struct Case {
    const char* path;
    const char* file;
  };
  for (const Case& c :
       {Case{"edge_cases/missing_textures/BoxTextured_png_removed/BoxTextured.gltf",
             "CesiumLogoFlat.png"},
        Case{"edge_cases/missing_textures/Quaternius_Pine_5_textures_absent/Pine_5.gltf", ".png"}}) {
    const fs::path path = Asset(c.path);
    if (!fs::exists(path)) continue;
    absl::StatusOr<Scene> scene = LoadGltfScene(path);
    ASSERT_EQ(scene.status().code(), absl::StatusCode::kInvalidArgument) << c.path;
    EXPECT_NE(scene.status().message().find(c.file), std::string::npos) << scene.status();
  }
}

TEST(GltfFeaturesTest, MaskMaterialWhoseImageHasNoAlphaWarns) {
  const fs::path path = Asset("edge_cases/alpha_broken_PolyHaven_Fern02/fern_02.glb");
  SKIP_IF_MISSING(path);
  absl::StatusOr<Scene> scene = LoadGltfScene(path);
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_TRUE(HasWarning(*scene, "is MASK but its base colour image")) << AllWarnings(*scene);
  EXPECT_TRUE(HasWarning(*scene, "has no alpha channel")) << AllWarnings(*scene);
}

// A textured triangle whose image is `png_channels` channels, with
// `material_json` members added to its material.
std::string TexturedTriangle(int png_channels, const std::string& material_json) {
  std::vector<uint16_t> samples(2 * 2 * png_channels, 200);
  const std::string png = Base64(MakePng(2, 2, png_channels, 8, samples));
  TriangleOptions o;
  o.extra_top_level = R"("images": [{"uri": "data:image/png;base64,)" + png +
                      R"("}], "textures": [{"source": 0}], "materials": [{)" + material_json +
                      R"("pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],)";
  o.primitive_extra = R"(, "material": 0)";
  return TriangleGltf(o);
}

// A transmissive material bakes opaque (the unlit bake has no refraction):
// said in a warning naming the material, not left for the artist to find.
TEST(GltfFeaturesTest, TransmissiveMaterialsWarnThatTheyBakeOpaque) {
  const std::string glass = R"("name": "glass", "extensions": {"KHR_materials_transmission": )";
  absl::StatusOr<Scene> clear = FromText(TexturedTriangle(4, glass + R"({"transmissionFactor": 1.0}}, )"));
  ASSERT_TRUE(clear.ok()) << clear.status();
  EXPECT_TRUE(HasWarning(*clear, "is transmissive (KHR_materials_transmission, transmissionFactor 1)"))
      << AllWarnings(*clear);
  EXPECT_TRUE(HasWarning(*clear, "glass")) << AllWarnings(*clear);
  absl::StatusOr<Scene> none = FromText(TexturedTriangle(4, glass + R"({"transmissionFactor": 0.0}}, )"));
  ASSERT_TRUE(none.ok()) << none.status();
  EXPECT_TRUE(none->warnings.empty()) << AllWarnings(*none);
  const fs::path vase = Asset("vegetation/GlassVaseFlowers/glTF-Binary/GlassVaseFlowers.glb");
  SKIP_IF_MISSING(vase);
  absl::StatusOr<Scene> scene = LoadGltfScene(vase);
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_TRUE(HasWarning(*scene, "is transmissive")) << AllWarnings(*scene);
}

TEST(GltfFeaturesTest, MaskWarningDependsOnTheImagesAlphaChannel) {
  absl::StatusOr<Scene> rgb = FromText(TexturedTriangle(3, R"("alphaMode": "MASK", )"));
  ASSERT_TRUE(rgb.ok()) << rgb.status();
  EXPECT_TRUE(HasWarning(*rgb, "has no alpha channel")) << AllWarnings(*rgb);
  absl::StatusOr<Scene> rgba = FromText(TexturedTriangle(4, R"("alphaMode": "MASK", )"));
  ASSERT_TRUE(rgba.ok()) << rgba.status();
  EXPECT_TRUE(rgba->warnings.empty()) << AllWarnings(*rgba);
  absl::StatusOr<Scene> opaque = FromText(TexturedTriangle(3, ""));
  ASSERT_TRUE(opaque.ok()) << opaque.status();
  EXPECT_TRUE(opaque->warnings.empty()) << AllWarnings(*opaque);
}

TEST(GltfFeaturesTest, UndecodableImageFormatIsDroppedWithAWarning) {
  std::vector<uint8_t> ktx2 = {0xAB, 'K', 'T', 'X', ' ', '2', '0', 0xBB, '\r', '\n', 0x1A, '\n'};
  ktx2.resize(64, 0);
  TriangleOptions o;
  o.extra_top_level = R"("images": [{"uri": "data:application/octet-stream;base64,)" + Base64(ktx2) +
                      R"("}], "textures": [{"source": 0}], "materials": [{)"
                      R"("pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],)";
  o.primitive_extra = R"(, "material": 0)";
  absl::StatusOr<Scene> scene = FromText(TriangleGltf(o));
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_EQ(scene->materials[0].base_color_texture, -1);
  EXPECT_TRUE(HasWarning(*scene, "KTX2")) << AllWarnings(*scene);
}

TEST(GltfFeaturesTest, TextureTransformPerSlotWithTexCoordOverride) {
  const std::string material = R"("occlusionTexture": {"index": 0, "extensions":
      {"KHR_texture_transform": {"offset": [0.25, 0.5], "scale": [2, 3], "texCoord": 1}}},
      "normalTexture": {"index": 0, "texCoord": 1}, "emissiveTexture": {"index": 0,
      "texCoord": 5}, )";
  absl::StatusOr<Scene> scene = FromText(TexturedTriangle(4, material));
  ASSERT_TRUE(scene.ok()) << scene.status();
  const SceneMaterial& m = scene->materials[0];
  EXPECT_EQ(m.uv[kSlotBaseColor].tex_coord, 0);
  EXPECT_EQ(m.uv[kSlotBaseColor].transform, glm::mat3(1.0f));
  EXPECT_EQ(m.uv[kSlotNormal].tex_coord, 1);
  EXPECT_EQ(m.uv[kSlotOcclusion].tex_coord, 1);  // the override wins
  const glm::vec2 uv = glm::vec2(m.uv[kSlotOcclusion].transform * glm::vec3(1.0f, 1.0f, 1.0f));
  EXPECT_FLOAT_EQ(uv.x, 2.25f);
  EXPECT_FLOAT_EQ(uv.y, 3.5f);
  // TEXCOORD_5 does not exist here: set 0 with a warning.
  EXPECT_EQ(m.uv[kSlotEmissive].tex_coord, 0);
  EXPECT_TRUE(HasWarning(*scene, "TEXCOORD_5")) << AllWarnings(*scene);
}

TEST(GltfFeaturesTest, TextureTransformTestKeepsUvsAndCarriesTransforms) {
  const fs::path path =
      Asset("edge_cases/khronos/TextureTransformTest/glTF/TextureTransformTest.gltf");
  SKIP_IF_MISSING(path);
  absl::StatusOr<Scene> scene = LoadGltfScene(path);
  ASSERT_TRUE(scene.ok()) << scene.status();
  bool offset_u = false, rotation = false;
  for (const SceneMaterial& m : scene->materials) {
    const glm::mat3& t = m.uv[kSlotBaseColor].transform;
    if (m.name == "Offset U") offset_u = t[2][0] == 0.5f && t[2][1] == 0.0f;
    if (m.name == "Rotation") {
      // rotation 0.3927 (22.5 degrees): u' = c u + s v, v' = -s u + c v
      rotation = std::abs(t[0][0] - std::cos(0.39269908f)) < 1e-6f &&
                 std::abs(t[1][0] - std::sin(0.39269908f)) < 1e-6f;
    }
  }
  EXPECT_TRUE(offset_u);
  EXPECT_TRUE(rotation);
}

TEST(GltfFeaturesTest, BoxVertexColorsCarriesColor0) {
  const fs::path path = Asset("edge_cases/khronos/BoxVertexColors/glTF-Binary/BoxVertexColors.glb");
  SKIP_IF_MISSING(path);
  absl::StatusOr<Scene> scene = LoadGltfScene(path);
  ASSERT_TRUE(scene.ok()) << scene.status();
  int coloured = 0;
  for (const SceneVertex& v : scene->vertices) {
    EXPECT_EQ(v.color.a, 1.0f);  // VEC3 colours: alpha 1
    coloured += v.color != glm::vec4(1.0f) ? 1 : 0;
  }
  EXPECT_GT(coloured, static_cast<int>(scene->vertices.size()) / 2);
}

// COLOR_0 as normalized unsigned bytes (VEC4) and unsigned shorts (VEC3).
TEST(GltfFeaturesTest, NormalizedIntegerVertexColours) {
  struct Case {
    int component_type;  // 5121 ubyte, 5123 ushort
    const char* type;
    int components;
    int bytes_per_component;
  };
  for (const Case& c : {Case{5121, "VEC4", 4, 1}, Case{5123, "VEC3", 3, 2}}) {
    std::vector<uint8_t> bytes(36, 0);
    const float positions[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    std::memcpy(bytes.data(), positions, sizeof(positions));
    // Vertex i: channel k = max * (k + 1) / 4 (alpha, when present, = max).
    const uint32_t max = c.bytes_per_component == 1 ? 255 : 65535;
    const size_t stride = ((c.components * c.bytes_per_component + 3) / 4) * 4;  // 4-aligned
    const size_t colour_offset = bytes.size();
    bytes.resize(colour_offset + 3 * stride, 0);
    for (int v = 0; v < 3; ++v) {
      for (int k = 0; k < c.components; ++k) {
        const uint32_t value = k == 3 ? max : max * (k + 1) / 4;
        std::memcpy(bytes.data() + colour_offset + v * stride + k * c.bytes_per_component, &value,
                    c.bytes_per_component);
      }
    }
    const std::string gltf = std::string(R"({"asset": {"version": "2.0"}, "scene": 0,
      "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
      "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "COLOR_0": 1}}]}],
      "buffers": [{"byteLength": )") +
                             std::to_string(bytes.size()) +
                             R"(, "uri": "data:application/octet-stream;base64,)" + Base64(bytes) +
                             R"("}],
      "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                      {"buffer": 0, "byteOffset": 36, "byteLength": )" +
                             std::to_string(3 * stride) + R"(, "byteStride": )" +
                             std::to_string(stride) + R"(}],
      "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                     "min": [0, 0, 0], "max": [1, 1, 0]},
                    {"bufferView": 1, "componentType": )" +
                             std::to_string(c.component_type) +
                             R"(, "normalized": true, "count": 3, "type": ")" + c.type +
                             R"("}]})";
    absl::StatusOr<Scene> scene = FromText(gltf);
    ASSERT_TRUE(scene.ok()) << c.type << ": " << scene.status();
    ASSERT_EQ(scene->vertices.size(), 3u);
    for (const SceneVertex& v : scene->vertices) {
      EXPECT_NEAR(v.color.r, 0.25f, 0.003f) << c.type;
      EXPECT_NEAR(v.color.g, 0.5f, 0.003f) << c.type;
      EXPECT_NEAR(v.color.b, 0.75f, 0.003f) << c.type;
      EXPECT_EQ(v.color.a, 1.0f) << c.type;
    }
  }
}

TEST(GltfFeaturesTest, MultiUvTestCarriesTexcoord1) {
  const fs::path path = Asset("edge_cases/khronos/MultiUVTest/glTF-Binary/MultiUVTest.glb");
  SKIP_IF_MISSING(path);
  absl::StatusOr<Scene> scene = LoadGltfScene(path);
  ASSERT_TRUE(scene.ok()) << scene.status();
  int differ = 0;
  for (const SceneVertex& v : scene->vertices) differ += v.uv != v.uv1 ? 1 : 0;
  EXPECT_GT(differ, 0);
  EXPECT_EQ(scene->materials[0].uv[kSlotEmissive].tex_coord, 1);
}

TEST(GltfFeaturesTest, MorphTargetsApplyAtTheirDefaultWeights) {
  // The one target moves each vertex by its own position: weight 0.5 scales
  // the triangle by 1.5.
  TriangleOptions o;
  o.primitive_extra = R"(, "targets": [{"POSITION": 0}])";
  o.nodes = R"([{"mesh": 0, "weights": [0.5]}])";
  absl::StatusOr<Scene> scene = FromText(TriangleGltf(o));
  ASSERT_TRUE(scene.ok()) << scene.status();
  ASSERT_EQ(scene->vertices.size(), 3u);
  EXPECT_EQ(scene->vertices[1].position, glm::vec3(1.5f, 0, 0));
  EXPECT_EQ(scene->vertices[2].position, glm::vec3(0, 1.5f, 0));
  // Without weights the target has weight 0.
  o.nodes = R"([{"mesh": 0}])";
  scene = FromText(TriangleGltf(o));
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_EQ(scene->vertices[1].position, glm::vec3(1, 0, 0));
}

TEST(GltfFeaturesTest, SkinnedFoxIsInBindPoseIgnoringItsNodeTransform) {
  const fs::path path = Asset("props_pbr/Fox/glTF-Binary/Fox.glb");
  SKIP_IF_MISSING(path);
  absl::StatusOr<Scene> scene = LoadGltfScene(path);
  ASSERT_TRUE(scene.ok()) << scene.status();
  // POSITION min/max of the file: the bind pose is the mesh as stored.
  EXPECT_NEAR(scene->bounds_min.x, -12.5927f, 1e-3f);
  EXPECT_NEAR(scene->bounds_max.y, 78.9072f, 1e-3f);
  EXPECT_NEAR(scene->bounds_min.z, -88.0950f, 1e-3f);
  EXPECT_NEAR(scene->bounds_max.z, 66.6249f, 1e-3f);
  EXPECT_TRUE(HasWarning(*scene, "bind pose")) << AllWarnings(*scene);
}

TEST(TangentSpaceTest, AngleWeightedTangentsFollowTheUvGradient) {
  using gltf_internal::ComputeTangents;
  // A fan of 4 unequal triangles around vertex 0 in the z = 0 plane, uv =
  // (x, y): every tangent must be +X with w = +1, whatever the split.
  const std::vector<glm::vec3> p = {{0, 0, 0}, {1, 0, 0}, {0.2f, 1, 0}, {-1, 0.1f, 0},
                                    {0, -1, 0}};
  std::vector<glm::vec2> uv;
  for (const glm::vec3& q : p) uv.push_back({q.x, q.y});
  const std::vector<glm::vec3> n(p.size(), glm::vec3(0, 0, 1));
  const std::vector<uint32_t> tri = {0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 1};
  const std::vector<glm::vec4> t = ComputeTangents(p, n, uv, tri);
  for (const glm::vec4& v : t) {
    EXPECT_NEAR(v.x, 1.0f, 1e-5f);
    EXPECT_NEAR(v.y, 0.0f, 1e-5f);
    EXPECT_NEAR(v.z, 0.0f, 1e-5f);
    EXPECT_EQ(v.w, 1.0f);
  }
  // Mirrored UVs (u = -x) flip the handedness and the tangent.
  for (glm::vec2& u : uv) u.x = -u.x;
  for (const glm::vec4& v : ComputeTangents(p, n, uv, tri)) {
    EXPECT_NEAR(v.x, -1.0f, 1e-5f);
    EXPECT_EQ(v.w, -1.0f);
  }
}

}  // namespace
}  // namespace impostor
