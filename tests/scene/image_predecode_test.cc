// A load's textures decoded side by side (image_predecode.h): the same
// texels and the same refusals as decoding each when first used.
#include "worker/scene/image_predecode.h"

#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "tests/scene/test_assets.h"
#include "worker/scene/gltf_loader.h"
#include "worker/scene/scene_wire.h"
#include "worker/scene/texel_arena.h"
#include "worker/scene/texture_decode.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using gltf_internal::DecodeImageRgba8;
using gltf_internal::FitsDecodingAtOnce;
using gltf_internal::LoadCost;
using gltf_internal::PeakDecodeBytes;
using gltf_internal::PredecodeImages;
using gltf_internal::ProbeImage;

// A 64x64 RGB PNG whose texels depend on `seed`.
std::vector<uint8_t> Png(int seed) {
  std::vector<uint16_t> samples(64 * 64 * 3);
  for (size_t i = 0; i < samples.size(); ++i) samples[i] = static_cast<uint16_t>((i * 37 + seed * 101) % 256);
  return testing::MakePng(64, 64, 3, 8, samples);
}

// Bytes whose header reads (so the load's budget counts the image) but
// whose pixel data does not inflate.
std::vector<uint8_t> Corrupt(std::vector<uint8_t> png) {
  const std::string text(png.begin(), png.end());
  const size_t idat = text.find("IDAT");
  for (size_t i = idat + 4; i < idat + 40 && i < png.size(); ++i) png[i] = 0xFF;
  return png;
}

// A triangle whose material uses three images: base colour image 1, normal
// image 0, occlusion image 2 (the material table meets them in that order).
fs::path WriteThreeTextureGltf(const fs::path& dir, const std::vector<std::vector<uint8_t>>& pngs) {
  testing::TriangleOptions o;
  o.primitive_extra = R"(, "material": 0)";
  o.extra_top_level = R"(
  "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 1}},
                 "normalTexture": {"index": 0}, "occlusionTexture": {"index": 2}}],
  "textures": [{"source": 0}, {"source": 1}, {"source": 2}],
  "images": [)";
  for (size_t i = 0; i < pngs.size(); ++i) {
    o.extra_top_level += std::string(i ? "," : "") + R"({"uri": "data:image/png;base64,)" + testing::Base64(pngs[i]) + R"("})";
  }
  o.extra_top_level += "],";
  fs::create_directories(dir);
  testing::WriteFile(dir / "three.gltf", testing::TriangleGltf(o));
  return dir / "three.gltf";
}

// Limits that pass a load decoding one image at a time but leave no room
// for all three decodes at once (FitsDecodingAtOnce false).
GltfLoadLimits OneAtATime(const std::vector<std::vector<uint8_t>>& pngs) {
  uint64_t texels = 0, peak = 0;
  for (const auto& png : pngs) {
    const auto header = ProbeImage(png, "test");
    texels += static_cast<uint64_t>(header->width) * header->height * 4;
    peak = std::max(peak, PeakDecodeBytes(*header));
  }
  GltfLoadLimits limits;
  limits.max_texture_bytes = texels + peak;
  return limits;
}

TEST(ImagePredecode, TheSceneIsTheSameDecodedSideBySideOrOneAtATime) {
  const std::vector<std::vector<uint8_t>> pngs = {Png(1), Png(2), Png(3)};
  const fs::path dir = testing::MakeScratchDir("predecode");
  const fs::path gltf = WriteThreeTextureGltf(dir, pngs);
  const absl::StatusOr<Scene> side_by_side = LoadGltfScene(gltf, {});
  const absl::StatusOr<Scene> one_at_a_time = LoadGltfScene(gltf, OneAtATime(pngs));
  fs::remove_all(dir);
  ASSERT_TRUE(side_by_side.ok()) << side_by_side.status();
  ASSERT_TRUE(one_at_a_time.ok()) << one_at_a_time.status();
  ASSERT_EQ(side_by_side->textures.size(), 3u);
  std::string a, b;
  EncodeScene(*side_by_side, &a);
  EncodeScene(*one_at_a_time, &b);
  EXPECT_TRUE(a == b) << "the scenes differ";
  // Textures in the material table's order of use: base colour (image 1) first.
  const auto first = DecodeImageRgba8(pngs[1], 16384, uint64_t{1} << 30, "x");
  ASSERT_TRUE(first.ok());
  EXPECT_EQ(side_by_side->textures[0].rgba8, first->rgba8);
}

// Two images that do not decode: the one named is the first the material
// table uses (image 1, the base colour), as when each was decoded on use.
TEST(ImagePredecode, TheFirstBadImageInUseOrderIsNamed) {
  const std::vector<std::vector<uint8_t>> pngs = {Corrupt(Png(1)), Corrupt(Png(2)), Png(3)};
  const fs::path dir = testing::MakeScratchDir("predecode_bad");
  const fs::path gltf = WriteThreeTextureGltf(dir, pngs);
  for (const GltfLoadLimits& limits : {GltfLoadLimits{}, OneAtATime(pngs)}) {
    const absl::StatusOr<Scene> scene = LoadGltfScene(gltf, limits);
    EXPECT_EQ(scene.status().code(), absl::StatusCode::kInvalidArgument) << scene.status();
    EXPECT_NE(scene.status().message().find("image[1]"), std::string::npos) << scene.status();
  }
  fs::remove_all(dir);
}

TEST(ImagePredecode, DecodesEachImageAsAloneAndIntoTheInstalledArena) {
  tinygltf::Model model;
  for (int i = 0; i < 6; ++i) {
    tinygltf::Image image;
    const std::vector<uint8_t> png = i == 4 ? Corrupt(Png(i)) : Png(i);
    image.image = png;
    image.as_is = true;
    image.name = "img" + std::to_string(i);
    model.images.push_back(image);
  }
  const int fd = ::memfd_create("predecode-test", MFD_CLOEXEC);
  ASSERT_GE(fd, 0);
  TexelArena arena(fd);
  gltf_internal::PredecodedImages decoded;
  {
    ScopedTexelArena use(&arena);
    decoded = PredecodeImages(model, {0, 1, 2, 3, 4, 5}, {});
  }
  ASSERT_EQ(decoded.size(), 6u);
  std::set<uint64_t> offsets;
  for (int i = 0; i < 6; ++i) {
    const auto alone = DecodeImageRgba8(model.images[i].image, 16384, uint64_t{1} << 30, gltf_internal::ImageWhat(model, i));
    const auto& got = decoded.at(i);
    ASSERT_EQ(got.ok(), alone.ok()) << i << ": " << got.status();
    if (!got.ok()) {
      EXPECT_EQ(got.status(), alone.status());
      EXPECT_NE(got.status().message().find("image[4] 'img4'"), std::string::npos) << got.status();
      continue;
    }
    EXPECT_EQ(got->rgba8, alone->rgba8) << i;
    EXPECT_EQ(got->rgba8.arena(), &arena) << i;
    offsets.insert(got->rgba8.arena_offset());
  }
  EXPECT_EQ(offsets.size(), 5u) << "each image in its own region of the arena";
  decoded.clear();
  ::close(fd);
}

TEST(ImagePredecode, OnlyWhenTheBudgetHoldsEveryDecodeAtOnce) {
  LoadCost cost;
  cost.decodable_images = {0, 1, 2};
  cost.texture_bytes = 300;
  cost.texture_peak_bytes = 400;
  cost.texture_peak_sum_bytes = 1000;
  cost.total_bytes = 2000;  // with the largest peak
  GltfLoadLimits limits;
  limits.max_texture_bytes = 1300;
  limits.max_load_bytes = 2600;
  EXPECT_TRUE(FitsDecodingAtOnce(cost, limits));
  limits.max_texture_bytes = 1299;  // the texels and all peaks: 1300
  EXPECT_FALSE(FitsDecodingAtOnce(cost, limits));
  limits.max_texture_bytes = 1300;
  limits.max_load_bytes = 2599;  // 2000 - 400 + 1000 = 2600
  EXPECT_FALSE(FitsDecodingAtOnce(cost, limits));
  limits.max_load_bytes = 2600;
  cost.decodable_images = {0};  // one image: nothing to overlap
  EXPECT_FALSE(FitsDecodingAtOnce(cost, limits));
}

}  // namespace
}  // namespace impostor
