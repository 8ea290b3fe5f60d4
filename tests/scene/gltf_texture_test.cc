// Texture decoding and material conversion on generated glTF files.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "tests/scene/test_assets.h"
#include "worker/scene/gltf_loader.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::TriangleGltf;
using testing::TriangleOptions;

// A triangle whose material uses `png` as base colour and (same image,
// other sampler) as occlusion.
absl::StatusOr<Scene> LoadWithTexture(const std::vector<uint8_t>& png,
                                      const GltfLoadLimits& limits = {}) {
  TriangleOptions o;
  o.primitive_extra = R"(, "material": 0)";
  o.extra_top_level = R"(
  "materials": [{"name": "m", "alphaMode": "MASK", "alphaCutoff": 0.3, "doubleSided": true,
                 "pbrMetallicRoughness": {"baseColorTexture": {"index": 0},
                                          "baseColorFactor": [0.5, 0.5, 0.5, 1],
                                          "metallicFactor": 0.25},
                 "occlusionTexture": {"index": 1, "strength": 0.75}}],
  "samplers": [{"wrapS": 33071, "wrapT": 33648}],
  "textures": [{"source": 0, "sampler": 0}, {"source": 0}],
  "images": [{"uri": "data:image/png;base64,)" +
                      testing::Base64(png) + R"("}],)";
  const fs::path dir = testing::MakeScratchDir("tex");
  testing::WriteFile(dir / "tex.gltf", TriangleGltf(o));
  absl::StatusOr<Scene> scene = LoadGltfScene(dir / "tex.gltf", limits);
  fs::remove_all(dir);
  return scene;
}

TEST(GltfTextureTest, ChannelExpansionAndBitDepth) {
  struct Case {
    const char* name;
    int channels, bits;
    std::vector<uint16_t> samples;  // one pixel
    std::vector<uint8_t> rgba;      // expected
  };
  const Case cases[] = {
      {"grey 8", 1, 8, {77}, {77, 77, 77, 255}},
      {"grey+alpha 8", 2, 8, {77, 9}, {77, 77, 77, 9}},
      {"rgb 8", 3, 8, {1, 2, 3}, {1, 2, 3, 255}},
      {"rgba 8", 4, 8, {1, 2, 3, 4}, {1, 2, 3, 4}},
      {"rgb 16", 3, 16, {0x1234, 0xABCD, 0xFFFF}, {0x12, 0xAB, 0xFF, 255}},
      {"grey 16", 1, 16, {0x8000}, {0x80, 0x80, 0x80, 255}},
      {"rgba 16", 4, 16, {0, 0x0100, 0xFE00, 0x7F00}, {0, 1, 0xFE, 0x7F}},
  };
  for (const Case& c : cases) {
    const absl::StatusOr<Scene> scene =
        LoadWithTexture(testing::MakePng(1, 1, c.channels, c.bits, c.samples));
    ASSERT_TRUE(scene.ok()) << c.name << ": " << scene.status();
    ASSERT_EQ(scene->textures.size(), 2u) << c.name;
    EXPECT_EQ(scene->textures[0].rgba8, c.rgba) << c.name;
  }
}

TEST(GltfTextureTest, MaterialAndSamplerFields) {
  std::vector<uint16_t> samples(4 * 3 * 4, 200);
  const absl::StatusOr<Scene> scene = LoadWithTexture(testing::MakePng(4, 3, 4, 8, samples));
  ASSERT_TRUE(scene.ok()) << scene.status();
  ASSERT_EQ(scene->materials.size(), 1u);
  const SceneMaterial& m = scene->materials[0];
  EXPECT_EQ(m.name, "m");
  EXPECT_EQ(m.alpha_mode, AlphaMode::kMask);
  EXPECT_FLOAT_EQ(m.alpha_cutoff, 0.3f);
  EXPECT_TRUE(m.double_sided);
  EXPECT_EQ(m.base_color_factor, glm::vec4(0.5f, 0.5f, 0.5f, 1.0f));
  EXPECT_FLOAT_EQ(m.metallic_factor, 0.25f);
  EXPECT_FLOAT_EQ(m.roughness_factor, 1.0f);
  EXPECT_FLOAT_EQ(m.occlusion_strength, 0.75f);
  ASSERT_EQ(scene->textures.size(), 2u);  // same image, two sampler/colour-space uses
  const SceneTexture& base = scene->textures[m.base_color_texture];
  const SceneTexture& ao = scene->textures[m.occlusion_texture];
  EXPECT_TRUE(base.srgb);
  EXPECT_FALSE(ao.srgb);
  EXPECT_EQ(base.wrap_s, 33071);
  EXPECT_EQ(base.wrap_t, 33648);
  EXPECT_EQ(ao.wrap_s, 10497);
  EXPECT_EQ(base.width, 4);
  EXPECT_EQ(base.height, 3);
  EXPECT_EQ(base.rgba8, ao.rgba8);
}

TEST(GltfTextureTest, OversizedImageIsRefusedBeforeDecoding) {
  // The header claims 20000 x 1; the limit is checked on the header.
  std::vector<uint16_t> samples(20000, 5);
  GltfLoadLimits limits;
  const absl::StatusOr<Scene> scene =
      LoadWithTexture(testing::MakePng(20000, 1, 1, 8, samples), limits);
  EXPECT_EQ(scene.status().code(), absl::StatusCode::kResourceExhausted) << scene.status();
  EXPECT_NE(std::string(scene.status().message())
                .find("20000x1, over GltfLoadLimits::max_texture_dimension = 16384"),
            std::string::npos)
      << scene.status();
}

TEST(GltfTextureTest, CorruptImageIsAnError) {
  std::vector<uint8_t> png = testing::MakePng(2, 2, 3, 8, std::vector<uint16_t>(12, 1));
  png.resize(png.size() - 20);  // cut into the IDAT chunk
  const absl::StatusOr<Scene> scene = LoadWithTexture(png);
  EXPECT_EQ(scene.status().code(), absl::StatusCode::kInvalidArgument) << scene.status();
  EXPECT_NE(std::string(scene.status().message()).find("image[0]"), std::string::npos)
      << scene.status();
}

// Found by the fuzzer: stb_image quotes an unknown chunk's raw type bytes
// in its error, and those may hold a newline. Job errors must stay one line.
TEST(GltfTextureTest, DecoderErrorsWithControlBytesStayOneLine) {
  std::vector<uint8_t> png = testing::MakePng(2, 2, 3, 8, std::vector<uint16_t>(12, 1));
  const std::vector<uint8_t> chunk = {0, 0, 0, 0, '\n', 'B', 'A', 'D', 0, 0, 0, 0};
  png.insert(png.begin() + 33, chunk.begin(), chunk.end());  // after signature + IHDR
  const absl::StatusOr<Scene> scene = LoadWithTexture(png);
  ASSERT_EQ(scene.status().code(), absl::StatusCode::kInvalidArgument) << scene.status();
  EXPECT_EQ(std::string(scene.status().message()).find('\n'), std::string::npos) << scene.status();
  EXPECT_NE(std::string(scene.status().message()).find("image[0]"), std::string::npos) << scene.status();
}

}  // namespace
}  // namespace impostor
