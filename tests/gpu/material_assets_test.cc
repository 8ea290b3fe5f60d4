// Bakes real glTF sample assets (../shared/assets) through the loader and the
// Vulkan renderer (lavapipe suffices) and checks what the frames show:
// vertex colours, the second UV set, KHR_texture_transform, mirrored
// (negative-scale) nodes, GPU instancing, a skinned mesh in bind pose and
// MASK/BLEND coverage. Frames are small (128..256 px) so each test takes
// well under a second or two.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <glm/geometric.hpp>
#include <memory>
#include <string>
#include <vector>

#include "common/atlas/frame_camera.h"
#include "worker/gpu/atlas_renderer.h"
#include "worker/scene/bounding_sphere.h"
#include "worker/scene/gltf_loader.h"
#include "worker/scene/scene.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

fs::path Asset(const std::string& relative) {
  const char* env = std::getenv("IMPOSTOR_ASSETS_DIR");
  return fs::path(env != nullptr ? env : IMPOSTOR_ASSETS_DIR) / relative;
}

#define SKIP_IF_MISSING(path) \
  if (!fs::exists(path)) GTEST_SKIP() << "asset missing: " << (path)

// One orthographic frame looking along -direction, filling the whole atlas.
FrameCamera CameraFrom(glm::vec3 direction, int size) {
  FrameCamera c;
  c.direction = glm::normalize(direction);
  c.up = CameraUpFor(c.direction);
  c.right = glm::cross(c.up, c.direction);
  c.tile = {0, 0, size, size};
  return c;
}

// The scene with only the batches `keep` accepts (vertices, materials and
// bounds unchanged, so the framing matches the full scene's).
Scene Only(const Scene& scene, const std::function<bool(const SceneBatch&)>& keep) {
  Scene out = scene;
  out.batches.clear();
  for (const SceneBatch& b : scene.batches) {
    if (keep(b)) out.batches.push_back(b);
  }
  return out;
}

std::function<bool(const SceneBatch&)> MaterialNamed(const Scene& scene, const std::string& name) {
  return [&scene, name](const SceneBatch& b) { return scene.materials[b.material].name == name; };
}

int Covered(const AtlasImages& img) {
  int n = 0;
  for (size_t i = 3; i < img.albedo_alpha.size(); i += 4) n += img.albedo_alpha[i] > 0 ? 1 : 0;
  return n;
}

// Texels whose albedo differs by more than `tolerance` in some channel.
int DifferentTexels(const AtlasImages& a, const AtlasImages& b, int tolerance = 8) {
  int n = 0;
  for (size_t i = 0; i + 3 < a.albedo_alpha.size(); i += 4) {
    bool diff = false;
    for (int c = 0; c < 4; ++c) {
      diff |= std::abs(a.albedo_alpha[i + c] - b.albedo_alpha[i + c]) > tolerance;
    }
    n += diff ? 1 : 0;
  }
  return n;
}

struct Extent {
  int min_x = 1 << 30, min_y = 1 << 30, max_x = -1, max_y = -1;
  double Aspect() const { return static_cast<double>(max_x - min_x + 1) / (max_y - min_y + 1); }
};

Extent CoveredExtent(const AtlasImages& img) {
  Extent e;
  for (int y = 0; y < img.height; ++y) {
    for (int x = 0; x < img.width; ++x) {
      if (img.albedo_alpha[(static_cast<size_t>(y) * img.width + x) * 4 + 3] == 0) continue;
      e.min_x = std::min(e.min_x, x);
      e.max_x = std::max(e.max_x, x);
      e.min_y = std::min(e.min_y, y);
      e.max_y = std::max(e.max_y, y);
    }
  }
  return e;
}

class MaterialAssetsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    absl::StatusOr<std::unique_ptr<AtlasRenderer>> r = AtlasRenderer::Create();
    if (r.ok()) renderer_ = std::move(*r).release();
  }
  static void TearDownTestSuite() {
    delete renderer_;
    renderer_ = nullptr;
  }
  void SetUp() override { ASSERT_NE(renderer_, nullptr) << "no Vulkan device"; }

  static Scene Load(const fs::path& path) {
    absl::StatusOr<Scene> scene = LoadGltfScene(path);
    EXPECT_TRUE(scene.ok()) << scene.status();
    return scene.ok() ? *std::move(scene) : Scene{};
  }

  // Renders `scene` framed by `sphere` (default: the scene's own) from
  // `direction` into a size x size image.
  static AtlasImages Render(const Scene& scene, glm::vec3 direction, int size = 128,
                            const BoundingSphere* sphere = nullptr) {
    const BoundingSphere s = sphere != nullptr ? *sphere : ComputeBoundingSphere(scene);
    absl::StatusOr<AtlasImages> img =
        renderer_->Render(scene, s, {CameraFrom(direction, size)}, size, {}, nullptr);
    EXPECT_TRUE(img.ok()) << img.status();
    return img.ok() ? *std::move(img) : AtlasImages{};
  }

  static AtlasRenderer* renderer_;
};

AtlasRenderer* MaterialAssetsTest::renderer_ = nullptr;

TEST_F(MaterialAssetsTest, BoxVertexColorsShowsItsVertexColours) {
  const fs::path path = Asset("edge_cases/khronos/BoxVertexColors/glTF-Binary/BoxVertexColors.glb");
  SKIP_IF_MISSING(path);
  const Scene scene = Load(path);
  const AtlasImages img = Render(scene, {1, 1, 1});
  // Without COLOR_0 the box is the default white material everywhere;
  // with it, most of the box is clearly coloured (saturated texels).
  int covered = 0, saturated = 0;
  for (size_t i = 0; i < img.albedo_alpha.size(); i += 4) {
    if (img.albedo_alpha[i + 3] == 0) continue;
    ++covered;
    const int r = img.albedo_alpha[i], g = img.albedo_alpha[i + 1], b = img.albedo_alpha[i + 2];
    saturated += std::max({r, g, b}) - std::min({r, g, b}) > 60 ? 1 : 0;
  }
  ASSERT_GT(covered, 1000);
  EXPECT_GT(saturated, covered / 2) << saturated << " of " << covered << " texels coloured";

  Scene white = scene;
  for (SceneVertex& v : white.vertices) v.color = glm::vec4(1.0f);
  const AtlasImages plain = Render(white, {1, 1, 1});
  EXPECT_GT(DifferentTexels(img, plain), covered / 2);
  for (size_t i = 0; i < plain.albedo_alpha.size(); i += 4) {
    if (plain.albedo_alpha[i + 3] == 0) continue;
    ASSERT_EQ(plain.albedo_alpha[i], 255);  // default material: white
  }
}

TEST_F(MaterialAssetsTest, MultiUvTestReadsTheSecondUvSet) {
  const fs::path path = Asset("edge_cases/khronos/MultiUVTest/glTF-Binary/MultiUVTest.glb");
  SKIP_IF_MISSING(path);
  const Scene scene = Load(path);
  ASSERT_EQ(scene.materials.size(), 1u);
  // The emissive map reads TEXCOORD_1; the base colour TEXCOORD_0.
  EXPECT_EQ(scene.materials[0].uv[kSlotEmissive].tex_coord, 1);
  EXPECT_EQ(scene.materials[0].uv[kSlotBaseColor].tex_coord, 0);
  const AtlasImages set0 = Render(scene, {1, 0.5f, 1});
  Scene uv1 = scene;
  uv1.materials[0].uv[kSlotBaseColor].tex_coord = 1;
  const AtlasImages set1 = Render(uv1, {1, 0.5f, 1});
  ASSERT_GT(Covered(set0), 1000);
  EXPECT_EQ(Covered(set0), Covered(set1));
  // The two sets map the texture differently: much of the box changes.
  EXPECT_GT(DifferentTexels(set0, set1), Covered(set0) / 5);
  // And the shader really reads uv1: copying uv1 into uv0 gives set1's
  // picture through set 0.
  Scene copied = scene;
  for (SceneVertex& v : copied.vertices) v.uv = v.uv1;
  EXPECT_LT(DifferentTexels(Render(copied, {1, 0.5f, 1}), set1, 2), Covered(set0) / 100);
}

TEST_F(MaterialAssetsTest, TextureTransformTestMatchesTransformedUvs) {
  const fs::path path =
      Asset("edge_cases/khronos/TextureTransformTest/glTF/TextureTransformTest.gltf");
  SKIP_IF_MISSING(path);
  const Scene scene = Load(path);
  const AtlasImages shader = Render(scene, {0, 0, 1}, 256);
  ASSERT_GT(Covered(shader), 5000);
  // Reference: the transform applied on the CPU to each vertex's UV (each
  // vertex is used by one material here) and identity in the shader.
  Scene cpu = scene;
  std::vector<int> material_of(scene.vertices.size(), -1);
  for (const SceneBatch& b : scene.batches) {
    for (uint32_t i = b.first_index; i < b.first_index + b.index_count; ++i) {
      material_of[scene.indices[i]] = b.material;
    }
  }
  int transformed = 0;
  for (size_t v = 0; v < cpu.vertices.size(); ++v) {
    if (material_of[v] < 0) continue;
    const glm::mat3& t = scene.materials[material_of[v]].uv[kSlotBaseColor].transform;
    transformed += t != glm::mat3(1.0f) ? 1 : 0;
    cpu.vertices[v].uv = glm::vec2(t * glm::vec3(cpu.vertices[v].uv, 1.0f));
  }
  ASSERT_GT(transformed, 0);
  for (SceneMaterial& m : cpu.materials) m.uv[kSlotBaseColor].transform = glm::mat3(1.0f);
  const AtlasImages reference = Render(cpu, {0, 0, 1}, 256);
  EXPECT_LT(DifferentTexels(shader, reference, 12), Covered(shader) / 100);
  // Ignoring the transform would change the picture a lot.
  Scene ignored = scene;
  for (SceneMaterial& m : ignored.materials) m.uv[kSlotBaseColor].transform = glm::mat3(1.0f);
  EXPECT_GT(DifferentTexels(Render(ignored, {0, 0, 1}, 256), shader), Covered(shader) / 10);
}

TEST_F(MaterialAssetsTest, NegativeScaleTestMirroredPartIsNotInsideOut) {
  const fs::path path =
      Asset("edge_cases/khronos/NegativeScaleTest/glTF-Binary/NegativeScaleTest.glb");
  SKIP_IF_MISSING(path);
  const Scene scene = Load(path);
  const BoundingSphere sphere = ComputeBoundingSphere(scene);
  // Single-sided batches under a mirroring node transform.
  const auto mirrored = [&](const SceneBatch& b) {
    return b.flipped_winding && !scene.materials[b.material].double_sided;
  };
  const Scene part = Only(scene, mirrored);
  ASSERT_FALSE(part.batches.empty());
  Scene wrong = part;  // winding not flipped: drawn inside out
  for (SceneBatch& b : wrong.batches) b.flipped_winding = false;
  // Over the six axis views, the surfaces drawn must face the camera
  // (scene-space normal . view direction > 0); inside out, the faces seen
  // are back faces whose normals point away.
  const auto facing_fraction = [&](const Scene& s, int* covered_total) {
    int covered = 0, facing = 0;
    for (const glm::vec3 d : {glm::vec3(1, 0, 0), glm::vec3(-1, 0, 0), glm::vec3(0, 1, 0),
                              glm::vec3(0, -1, 0), glm::vec3(0, 0, 1), glm::vec3(0, 0, -1)}) {
      const AtlasImages img = Render(s, d, 128, &sphere);
      for (size_t i = 0; i + 3 < img.normal_depth.size(); i += 4) {
        if (img.albedo_alpha[i + 3] == 0) continue;
        glm::vec3 n;
        for (int c = 0; c < 3; ++c) n[c] = img.normal_depth[i + c] / 65535.0f * 2.0f - 1.0f;
        ++covered;
        facing += glm::dot(n, d) > 0.0f ? 1 : 0;
      }
    }
    *covered_total = covered;
    return covered > 0 ? static_cast<double>(facing) / covered : 0.0;
  };
  int covered = 0, covered_wrong = 0;
  const double right = facing_fraction(part, &covered);
  const double inside_out = facing_fraction(wrong, &covered_wrong);
  std::printf("[ mirrored ] %d texels, %.3f facing the camera (inside out: %d, %.3f)\n", covered,
              right, covered_wrong, inside_out);
  EXPECT_GT(covered, 100);
  EXPECT_GT(right, 0.95);
  EXPECT_LT(inside_out, 0.5);
}

TEST_F(MaterialAssetsTest, SimpleInstancingDrawsEveryInstance) {
  const fs::path path =
      Asset("edge_cases/khronos/SimpleInstancing/glTF-Binary/SimpleInstancing.glb");
  SKIP_IF_MISSING(path);
  const Scene scene = Load(path);
  ASSERT_GT(scene.batches.size(), 1u);  // one batch per instance
  const BoundingSphere sphere = ComputeBoundingSphere(scene);
  const glm::vec3 dir(0.3f, 0.4f, 1.0f);
  const int all = Covered(Render(scene, dir, 256, &sphere));
  const SceneBatch first = scene.batches[0];
  const int one = Covered(Render(
      Only(scene, [&](const SceneBatch& b) { return b.first_index == first.first_index; }), dir,
      256, &sphere));
  ASSERT_GT(one, 0);
  // Every instance shows; overlaps hide some area, so ask for a third of
  // the unoccluded sum.
  EXPECT_GT(all, one * static_cast<int>(scene.batches.size()) / 3)
      << scene.batches.size() << " instances, one covers " << one << ", all " << all;
}

TEST_F(MaterialAssetsTest, FoxIsBakedInItsBindPose) {
  const fs::path path = Asset("props_pbr/Fox/glTF-Binary/Fox.glb");
  SKIP_IF_MISSING(path);
  const Scene scene = Load(path);
  // From the side (+X) the fox is long (z ~ -88..67) and not tall
  // (y ~ 0..79); from the front (+Z) it is narrow (x ~ +-12.6).
  const AtlasImages side = Render(scene, {1, 0, 0}, 256);
  const AtlasImages front = Render(scene, {0, 0, 1}, 256);
  ASSERT_GT(Covered(side), 2000);
  ASSERT_GT(Covered(front), 500);
  const double side_aspect = CoveredExtent(side).Aspect();
  const double front_aspect = CoveredExtent(front).Aspect();
  EXPECT_GT(side_aspect, 1.5);
  EXPECT_LT(side_aspect, 2.5);
  EXPECT_GT(front_aspect, 0.2);
  EXPECT_LT(front_aspect, 0.5);
  bool warned = false;
  for (const std::string& w : scene.warnings) warned |= w.find("bind pose") != std::string::npos;
  EXPECT_TRUE(warned);
}

// Sampler wrap modes through a KHR_texture_transform scale of 2 (uv 0..2
// across a quad): at u' = 1.25 and 1.75 a texture red on its left half and
// blue on its right reads red/blue (REPEAT), blue/red (MIRRORED_REPEAT) or
// blue/blue (CLAMP_TO_EDGE).
TEST_F(MaterialAssetsTest, WrapModesAreHonouredThroughTheUvTransform) {
  struct Case {
    int wrap;
    const char* name;
    bool red_at_125, red_at_175;
  };
  for (const Case& c : {Case{10497, "REPEAT", true, false}, Case{33648, "MIRRORED_REPEAT", false, true},
                        Case{33071, "CLAMP_TO_EDGE", false, false}}) {
    Scene scene;
    SceneMaterial m;
    m.base_color_texture = 0;
    m.uv[kSlotBaseColor].transform = glm::mat3(glm::vec3(2, 0, 0), glm::vec3(0, 1, 0), glm::vec3(0, 0, 1));
    scene.materials.push_back(m);
    SceneTexture t;
    t.width = 8;
    t.height = 1;
    t.srgb = true;
    t.wrap_s = t.wrap_t = c.wrap;
    for (int x = 0; x < 8; ++x) {
      const uint8_t red = x < 4 ? 255 : 0;
      for (uint8_t v : {red, uint8_t{0}, static_cast<uint8_t>(255 - red), uint8_t{255}}) t.rgba8.push_back(v);
    }
    scene.textures.push_back(t);
    const glm::vec3 corners[4] = {{-0.5f, -0.5f, 0}, {0.5f, -0.5f, 0}, {0.5f, 0.5f, 0}, {-0.5f, 0.5f, 0}};
    for (const glm::vec3& p : corners) {
      SceneVertex v;
      v.position = p;
      v.normal = glm::vec3(0, 0, 1);
      v.uv = glm::vec2(p.x + 0.5f, 0.5f - p.y);
      scene.vertices.push_back(v);
    }
    scene.indices = {0, 1, 2, 0, 2, 3};
    scene.batches.push_back({0, 6, 0, false});
    scene.bounds_min = glm::vec3(-0.5f, -0.5f, 0);
    scene.bounds_max = glm::vec3(0.5f, 0.5f, 0);
    const AtlasImages img = Render(scene, {0, 0, 1}, 64);
    ASSERT_EQ(img.width, 64);
    // Pixel columns 37 and 49 of row 32 sample u' ~ 1.24 and ~ 1.77.
    const auto is_red = [&](int x) {
      const size_t i = (32u * 64u + static_cast<size_t>(x)) * 4u;
      EXPECT_EQ(img.albedo_alpha[i + 3], 255) << c.name;
      return img.albedo_alpha[i] > 200 && img.albedo_alpha[i + 2] < 55;
    };
    const auto is_blue = [&](int x) {
      const size_t i = (32u * 64u + static_cast<size_t>(x)) * 4u;
      return img.albedo_alpha[i + 2] > 200 && img.albedo_alpha[i] < 55;
    };
    EXPECT_EQ(is_red(37), c.red_at_125) << c.name;
    EXPECT_EQ(is_blue(37), !c.red_at_125) << c.name;
    EXPECT_EQ(is_red(49), c.red_at_175) << c.name;
    EXPECT_EQ(is_blue(49), !c.red_at_175) << c.name;
  }
}

TEST_F(MaterialAssetsTest, TreeMaskLeavesAreCutOut) {
  const fs::path path = Asset("vegetation/TreeLowPoly_RicardoSanchez/scene_alphaMASK.gltf");
  SKIP_IF_MISSING(path);
  const Scene scene = Load(path);
  const BoundingSphere sphere = ComputeBoundingSphere(scene);
  const auto masked = [&](const SceneBatch& b) {
    return scene.materials[b.material].alpha_mode == AlphaMode::kMask;
  };
  const Scene leaves = Only(scene, masked);
  ASSERT_FALSE(leaves.batches.empty());
  Scene solid = leaves;
  for (SceneMaterial& m : solid.materials) m.alpha_mode = AlphaMode::kOpaque;
  const int cut = Covered(Render(leaves, {1, 0.3f, 0.5f}, 256, &sphere));
  const int full = Covered(Render(solid, {1, 0.3f, 0.5f}, 256, &sphere));
  std::printf("[ leaves ] MASK covers %d texels, the same cards OPAQUE %d\n", cut, full);
  // The leaf cards keep their leaves and lose the transparent parts.
  EXPECT_GT(cut, full / 10);
  EXPECT_LT(cut, full * 9 / 10);
}

TEST_F(MaterialAssetsTest, EmissiveMapIsFactorTimesStrengthTimesTexture) {
  // A quad facing +Z with emissive factor (1, 0.5, 0.25), no texture.
  Scene scene;
  SceneMaterial m;
  m.emissive_factor = glm::vec3(1.0f, 0.5f, 0.25f);
  scene.materials.push_back(m);
  const glm::vec3 corners[4] = {{-0.5f, -0.5f, 0}, {0.5f, -0.5f, 0}, {0.5f, 0.5f, 0}, {-0.5f, 0.5f, 0}};
  for (const glm::vec3& c : corners) {
    SceneVertex v;
    v.position = c;
    v.normal = glm::vec3(0, 0, 1);
    scene.vertices.push_back(v);
  }
  scene.indices = {0, 1, 2, 0, 2, 3};
  scene.batches.push_back({0, 6, 0, false});
  scene.bounds_min = glm::vec3(-0.5f, -0.5f, 0);
  scene.bounds_max = glm::vec3(0.5f, 0.5f, 0);

  // Not requested: no emissive map.
  EXPECT_TRUE(Render(scene, {0, 0, 1}, 64).emissive.empty());

  const auto centre = [&](float strength) {
    Scene s = scene;
    s.materials[0].emissive_strength = strength;
    renderer_->set_emissive(true);
    const AtlasImages img = Render(s, {0, 0, 1}, 64);
    renderer_->set_emissive(false);
    EXPECT_EQ(img.emissive.size(), img.albedo_alpha.size());
    std::vector<int> px(4, -1);
    if (img.emissive.size() != img.albedo_alpha.size()) return px;
    const size_t i = (32u * 64u + 32u) * 4u;
    for (int c = 0; c < 4; ++c) px[c] = img.emissive[i + c];
    // Empty texels stay 0,0,0,0.
    for (int c = 0; c < 4; ++c) EXPECT_EQ(img.emissive[c], 0);
    return px;
  };
  const auto expect_near = [](const std::vector<int>& got, const std::vector<int>& want) {
    for (int c = 0; c < 4; ++c) EXPECT_NEAR(got[c], want[c], 1) << "channel " << c;
  };
  // sRGB codes of 1, 0.5, 0.25: 255, 187.5, 137; A = coverage.
  expect_near(centre(1.0f), {255, 188, 137, 255});
  // KHR_materials_emissive_strength 2: 2, 1, 0.5, clamped to 1.
  expect_near(centre(2.0f), {255, 255, 188, 255});
}

TEST_F(MaterialAssetsTest, MultiUvTestEmissiveReadsTexcoord1) {
  const fs::path path = Asset("edge_cases/khronos/MultiUVTest/glTF-Binary/MultiUVTest.glb");
  SKIP_IF_MISSING(path);
  const Scene scene = Load(path);
  renderer_->set_emissive(true);
  const AtlasImages img = Render(scene, {1, 0.5f, 1});
  Scene uv0 = scene;
  uv0.materials[0].uv[kSlotEmissive].tex_coord = 0;
  const AtlasImages img0 = Render(uv0, {1, 0.5f, 1});
  renderer_->set_emissive(false);
  ASSERT_EQ(img.emissive.size(), img.albedo_alpha.size());
  int lit = 0, differ = 0, covered = 0;
  for (size_t i = 0; i < img.emissive.size(); i += 4) {
    EXPECT_EQ(img.emissive[i + 3], img.albedo_alpha[i + 3]);  // A = coverage
    if (img.emissive[i + 3] == 0) continue;
    ++covered;
    lit += img.emissive[i] + img.emissive[i + 1] + img.emissive[i + 2] > 30 ? 1 : 0;
    for (int c = 0; c < 3; ++c) {
      if (std::abs(img.emissive[i + c] - img0.emissive[i + c]) > 8) {
        ++differ;
        break;
      }
    }
  }
  ASSERT_GT(covered, 1000);
  EXPECT_GT(lit, covered / 20);
  EXPECT_GT(differ, covered / 20);
}

// Each cutout quad covers exactly the texels where its sampled alpha is at
// or above its cutoff (BLEND: 0.5). The reference renders the same quad
// OPAQUE with the texture's alpha copied into RGB (linear), so every covered
// texel's colour is the alpha the shader compared.
TEST_F(MaterialAssetsTest, AlphaBlendModeTestCutoffsGiveTheirCoverage) {
  const fs::path path = Asset("vegetation/AlphaBlendModeTest/glTF-Binary/AlphaBlendModeTest.glb");
  SKIP_IF_MISSING(path);
  const Scene scene = Load(path);
  const BoundingSphere sphere = ComputeBoundingSphere(scene);
  const glm::vec3 toward(0, 0, 1);
  struct Case {
    const char* material;
    double cutoff;
  };
  std::vector<double> ratios;
  for (const Case& c : {Case{"MatCutoff25", 0.25}, Case{"MatCutoffDefault", 0.5},
                        Case{"MatBlend", 0.5}, Case{"MatCutoff75", 0.75}}) {
    const Scene quad = Only(scene, MaterialNamed(scene, c.material));
    ASSERT_FALSE(quad.batches.empty()) << c.material;
    const int material = quad.batches[0].material;
    const SceneMaterial& m = scene.materials[material];
    EXPECT_EQ(m.alpha_mode, c.material == std::string("MatBlend") ? AlphaMode::kBlend
                                                                  : AlphaMode::kMask);
    EXPECT_FLOAT_EQ(c.material == std::string("MatBlend") ? 0.5f : m.alpha_cutoff, c.cutoff);
    const int covered = Covered(Render(quad, toward, 256, &sphere));

    Scene alpha_as_colour = quad;
    SceneMaterial& om = alpha_as_colour.materials[material];
    om.alpha_mode = AlphaMode::kOpaque;
    SceneTexture& t = alpha_as_colour.textures[om.base_color_texture];
    // RGB = the sRGB code of alpha, so that sampling (which decodes RGB to
    // linear before filtering, while alpha is filtered as stored) filters
    // the same values the shader's alpha sees.
    // (The copy shares the quad's texels: mutable_data makes them its own.)
    uint8_t* texels = t.rgba8.mutable_data();
    for (size_t i = 0; i < t.rgba8.size(); i += 4) {
      const double a = texels[i + 3] / 255.0;
      const double code = a <= 0.0031308 ? a * 12.92 : 1.055 * std::pow(a, 1.0 / 2.4) - 0.055;
      texels[i] = texels[i + 1] = texels[i + 2] = static_cast<uint8_t>(std::lround(code * 255.0));
    }
    const AtlasImages ref = Render(alpha_as_colour, toward, 256, &sphere);
    int quad_texels = 0, expected = 0;
    for (size_t i = 0; i < ref.albedo_alpha.size(); i += 4) {
      if (ref.albedo_alpha[i + 3] == 0) continue;
      ++quad_texels;
      // The attachment is sRGB: decode R back to the filtered alpha.
      const double srgb = ref.albedo_alpha[i] / 255.0;
      const double alpha =
          srgb <= 0.04045 ? srgb / 12.92 : std::pow((srgb + 0.055) / 1.055, 2.4);
      expected += alpha >= c.cutoff ? 1 : 0;
    }
    ASSERT_GT(quad_texels, 500) << c.material;
    const double ratio = static_cast<double>(covered) / quad_texels;
    const double expected_ratio = static_cast<double>(expected) / quad_texels;
    std::printf("[ coverage ] %s (cutoff %.2f): %.3f of its quad, expected %.3f\n", c.material,
                c.cutoff, ratio, expected_ratio);
    EXPECT_NEAR(ratio, expected_ratio, 0.02) << c.material;
    ratios.push_back(ratio);
  }
  // A higher cutoff covers less: 0.25 > 0.5 > 0.75.
  EXPECT_GT(ratios[0], ratios[1] + 0.05);
  EXPECT_GT(ratios[1], ratios[3] + 0.05);
}

}  // namespace
}  // namespace impostor
