#include "client/transfer/mesh_files.h"

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace impostor::sdk {
namespace {

namespace fs = std::filesystem;

const fs::path kAssets = IMPOSTOR_ASSETS_DIR;

std::vector<std::string> RelativePaths(const MeshFiles& files) {
  std::vector<std::string> out;
  for (const MeshFile& f : files.files) out.push_back(f.relative_path);
  std::sort(out.begin(), out.end());
  return out;
}

TEST(CollectMeshFiles, GltfWithBinAndPngs) {
  absl::StatusOr<MeshFiles> files = CollectMeshFiles(kAssets / "props_pbr/WaterBottle/glTF/WaterBottle.gltf");
  ASSERT_TRUE(files.ok()) << files.status();
  EXPECT_EQ(files->entry_name, "WaterBottle.gltf");
  EXPECT_EQ(RelativePaths(*files),
            (std::vector<std::string>{"WaterBottle.bin", "WaterBottle_baseColor.png", "WaterBottle_emissive.png",
                                      "WaterBottle_normal.png", "WaterBottle_occlusionRoughnessMetallic.png"}));
  for (const MeshFile& f : files->files) EXPECT_TRUE(fs::is_regular_file(f.local_path)) << f.local_path;
}

TEST(CollectMeshFiles, GltfWithTexturesInSubdirectory) {
  absl::StatusOr<MeshFiles> files = CollectMeshFiles(kAssets / "vegetation/TreeLowPoly_RicardoSanchez/scene.gltf");
  ASSERT_TRUE(files.ok()) << files.status();
  EXPECT_EQ(RelativePaths(*files),
            (std::vector<std::string>{"scene.bin", "textures/Leav_material_baseColor.png",
                                      "textures/tree_material_baseColor.jpeg"}));
}

TEST(CollectMeshFiles, GlbHasNoExternalFiles) {
  absl::StatusOr<MeshFiles> files = CollectMeshFiles(kAssets / "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb");
  ASSERT_TRUE(files.ok()) << files.status();
  EXPECT_EQ(files->entry_name, "DamagedHelmet.glb");
  EXPECT_TRUE(files->files.empty());
}

TEST(CollectMeshFiles, DataUrisAreEmbedded) {
  absl::StatusOr<MeshFiles> files = CollectMeshFiles(kAssets / "props_pbr/Box/glTF-Embedded/Box.gltf");
  ASSERT_TRUE(files.ok()) << files.status();
  EXPECT_TRUE(files->files.empty());
}

TEST(CollectMeshFiles, PercentEncodedUrisAreDecoded) {
  absl::StatusOr<MeshFiles> files =
      CollectMeshFiles(kAssets / "edge_cases/khronos/Box With Spaces/glTF/Box With Spaces.gltf");
  ASSERT_TRUE(files.ok()) << files.status();
  EXPECT_EQ(RelativePaths(*files), (std::vector<std::string>{"Box With Spaces.bin", "Normal Map.png",
                                                             "Roughness Metallic.png", "glTF Logo With Spaces.png"}));
}

TEST(PercentDecode, DecodesAndRejectsBadEscapes) {
  EXPECT_EQ(*PercentDecode("a%20b%2Fc"), "a b/c");
  EXPECT_FALSE(PercentDecode("a%2").ok());
  EXPECT_FALSE(PercentDecode("a%zz").ok());
}

// A scratch directory per test, removed afterwards.
class BadInputTest : public testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("impostor_mesh_files_" + std::to_string(::getpid()) + "_" +
            testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path Write(const std::string& name, const std::string& bytes) {
    const fs::path p = dir_ / name;
    fs::create_directories(p.parent_path());
    std::ofstream(p, std::ios::binary) << bytes;
    return p;
  }
  fs::path dir_;
};

std::string Gltf(const std::string& buffers, const std::string& images = "[]") {
  return R"({"asset":{"version":"2.0"},"buffers":)" + buffers + R"(,"images":)" + images + "}";
}

// A GLB whose JSON chunk is `json`, with header fields overridable.
std::string Glb(const std::string& json, uint32_t magic = 0x46546C67, uint32_t version = 2) {
  std::string padded = json;
  while (padded.size() % 4 != 0) padded += ' ';
  auto le32 = [](uint32_t v) {
    std::string s(4, '\0');
    for (int i = 0; i < 4; ++i) s[i] = static_cast<char>((v >> (8 * i)) & 0xff);
    return s;
  };
  const uint32_t total = 12 + 8 + static_cast<uint32_t>(padded.size());
  return le32(magic) + le32(version) + le32(total) + le32(static_cast<uint32_t>(padded.size())) +
         le32(0x4E4F534A) + padded;
}

struct BadCase {
  std::string name;
  std::string model_name;   // written into the scratch directory
  std::string model_bytes;
  absl::StatusCode code;
  std::string message_part;  // the error must mention this
};

TEST_F(BadInputTest, RefusedWithCodeAndReason) {
  Write("sub/ok.bin", "x");
  Write("outside.bin", "x");
  const std::vector<BadCase> cases = {
      {"dotdot_uri", "sub/m.gltf", Gltf(R"([{"uri":"../outside.bin","byteLength":1}])"),
       absl::StatusCode::kInvalidArgument, "../outside.bin"},
      {"dotdot_in_middle", "sub/m.gltf", Gltf(R"([{"uri":"a/../../outside.bin","byteLength":1}])"),
       absl::StatusCode::kInvalidArgument, "a/../../outside.bin"},
      {"percent_encoded_dotdot", "sub/m.gltf", Gltf(R"([{"uri":"%2E%2E/outside.bin","byteLength":1}])"),
       absl::StatusCode::kInvalidArgument, "%2E%2E/outside.bin"},
      {"absolute_path", "m.gltf", Gltf(R"([{"uri":"/etc/passwd","byteLength":1}])"),
       absl::StatusCode::kInvalidArgument, "/etc/passwd"},
      {"absolute_url", "m.gltf", Gltf(R"([{"uri":"https://example.com/a.bin","byteLength":1}])"),
       absl::StatusCode::kInvalidArgument, "https://example.com/a.bin"},
      {"file_url", "m.gltf", Gltf(R"([{"uri":"file:///tmp/a.bin","byteLength":1}])"),
       absl::StatusCode::kInvalidArgument, "file:///tmp/a.bin"},
      {"missing_buffer", "m.gltf", Gltf(R"([{"uri":"nope.bin","byteLength":1}])"), absl::StatusCode::kNotFound,
       "buffers[0].uri"},
      {"missing_image", "m.gltf", Gltf(R"([])", R"([{"uri":"sub/ok.bin"},{"uri":"tex/missing.png"}])"),
       absl::StatusCode::kNotFound, "images[1].uri \"tex/missing.png\""},
      {"invalid_json", "m.gltf", "{\"asset\": {\"version\": \"2.0\"", absl::StatusCode::kInvalidArgument,
       "invalid JSON"},
      {"json_not_object", "m.gltf", "[1,2]", absl::StatusCode::kInvalidArgument, "not an object"},
      {"buffers_not_array", "m.gltf", R"({"buffers":{"uri":"a.bin"}})", absl::StatusCode::kInvalidArgument,
       "\"buffers\" is not an array"},
      {"uri_not_string", "m.gltf", Gltf(R"([{"uri":7}])"), absl::StatusCode::kInvalidArgument,
       "buffers[0].uri is not a string"},
      {"bad_percent_escape", "m.gltf", Gltf(R"([{"uri":"a%zz.bin"}])"), absl::StatusCode::kInvalidArgument,
       "a%zz.bin"},
      {"glb_bad_magic", "m.glb", Glb("{}", 0x12345678), absl::StatusCode::kInvalidArgument,
       "corrupt GLB header: magic is not \"glTF\""},
      // Twelve zero bytes (the validator corpus's invalid_magic.glb): the
      // magic is what is wrong, not the length.
      {"glb_zeros", "m.glb", std::string(12, '\0'), absl::StatusCode::kInvalidArgument, "magic is not \"glTF\""},
      {"glb_bad_version", "m.glb", Glb("{}", 0x46546C67, 1), absl::StatusCode::kInvalidArgument, "version 1"},
      {"glb_truncated", "m.glb", Glb("{}").substr(0, 10), absl::StatusCode::kInvalidArgument,
       "file is 10 bytes, shorter than the 12-byte header and the first chunk's 8-byte header"},
      {"glb_chunk_overruns", "m.glb", Glb("{\"asset\":{}}").substr(0, 24), absl::StatusCode::kInvalidArgument,
       "truncated GLB"},
      {"glb_invalid_json", "m.glb", Glb("{oops"), absl::StatusCode::kInvalidArgument, "invalid JSON"},
      {"glb_dotdot_uri", "sub/m.glb", Glb(Gltf(R"([{"byteLength":4},{"uri":"../outside.bin"}])")),
       absl::StatusCode::kInvalidArgument, "buffers[1].uri \"../outside.bin\""},
      {"wrong_extension", "m.obj", "v 0 0 0", absl::StatusCode::kInvalidArgument, ".obj"},
  };
  for (const BadCase& c : cases) {
    const fs::path model = Write(c.model_name, c.model_bytes);
    absl::StatusOr<MeshFiles> files = CollectMeshFiles(model);
    ASSERT_FALSE(files.ok()) << c.name << ": accepted";
    EXPECT_EQ(files.status().code(), c.code) << c.name << ": " << files.status();
    EXPECT_NE(files.status().message().find(c.message_part), std::string::npos)
        << c.name << ": message \"" << files.status().message() << "\" lacks \"" << c.message_part << "\"";
    fs::remove(model);
  }
}

TEST_F(BadInputTest, MissingModelIsNotFound) {
  absl::StatusOr<MeshFiles> files = CollectMeshFiles(dir_ / "nope.gltf");
  EXPECT_EQ(files.status().code(), absl::StatusCode::kNotFound) << files.status();
}

TEST_F(BadInputTest, DotComponentsAndDuplicatesAreNormalised) {
  Write("a.bin", "x");
  Write("t/b.png", "y");
  const fs::path model = Write(
      "m.gltf", Gltf(R"([{"uri":"./a.bin"},{"uri":"a.bin"}])", R"([{"uri":"t//b.png"},{"uri":"data:image/png;base64,AA=="},{"bufferView":0}])"));
  absl::StatusOr<MeshFiles> files = CollectMeshFiles(model);
  ASSERT_TRUE(files.ok()) << files.status();
  EXPECT_EQ(RelativePaths(*files), (std::vector<std::string>{"a.bin", "t/b.png"}));
}

}  // namespace
}  // namespace impostor::sdk
