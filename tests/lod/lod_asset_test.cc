// The mesh levels of real assets: triangle counts against the requested
// ratios, errors growing level by level, every .glb passing the Khronos
// glTF validator with zero errors, and the textures referenced (not
// embedded) by every level, so they are stored once.
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include <gtest/gtest.h>

#include "tests/scene/test_assets.h"
#include "worker/lod/lod_glb_writer.h"
#include "worker/lod/lod_levels.h"
#include "worker/lod/lod_source.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

struct AssetCase {
  const char* name;
  const char* path;  // under the shared assets
  // The measured error itself grows level by level (not only the reported,
  // non-decreasing one): true where quadric simplification reaches every
  // ratio.
  bool strictly_increasing;
};

// Runs tools/gltf_validator/validate.sh; returns its exit status and keeps
// the report beside the file.
int Validate(const fs::path& glb, std::string* report) {
  const fs::path out = glb.string() + ".report.json";
  // Bounded: `timeout` ends a hung validator (exit 124, a failure naming the file).
  const std::string cmd =
      "timeout 300 " + std::string(IMPOSTOR_GLTF_VALIDATOR) + " '" + glb.string() + "' > '" + out.string() + "'";
  const int rc = std::system(cmd.c_str());
  std::ifstream in(out);
  std::stringstream text;
  text << in.rdbuf();
  *report = text.str();
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

class LodAssetTest : public ::testing::TestWithParam<AssetCase> {};

TEST_P(LodAssetTest, LevelsMeetRatiosAndValidate) {
  const fs::path entry = testing::Asset(GetParam().path);
  ASSERT_TRUE(fs::exists(entry)) << entry;
  auto source = LoadLodSource(entry, {});
  ASSERT_TRUE(source.ok()) << source.status();
  const fs::path dir = testing::MakeScratchDir(GetParam().name);
  const std::vector<std::string> textures = LodTextureFileNames(source->model);
  for (size_t i = 0; i < textures.size(); ++i) {
    const auto& bytes = source->model.images[i].image;
    std::ofstream(dir / textures[i], std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  }

  const std::vector<float> ratios = {1.0f, 0.5f, 0.1f};
  auto levels = BuildMeshLevels(*source, ratios, textures);
  ASSERT_TRUE(levels.ok()) << levels.status();
  const uint64_t original = (*levels)[0].mesh.triangles;
  for (size_t level = 0; level < ratios.size(); ++level) {
    const MeshLevel* built = &(*levels)[level].mesh;
    const float measured = (*levels)[level].measured_error;
    const double target = ratios[level] * original;
    std::cout << "figures asset=" << GetParam().name << " level=" << level << " ratio=" << ratios[level]
              << " triangles=" << built->triangles << " target=" << target << " error=" << built->error
              << " measured_error=" << measured << " sloppy=" << built->sloppy << " unlocked=" << built->unlocked
              << " welded=" << built->welded << " seconds=" << built->seconds << " glb_bytes=" << built->glb.size()
              << "\n";
    EXPECT_NEAR(static_cast<double>(built->triangles), target, 0.1 * target) << "level " << level;
    EXPECT_EQ(built->dropped_triangles, 0u) << "level " << level;
    if (level == 0) {
      EXPECT_EQ(built->error, 0.0f);
    } else {
      EXPECT_GT(built->error, 0.0f) << "level " << level;
      EXPECT_GE(built->error, (*levels)[level - 1].mesh.error) << "level " << level;
      if (GetParam().strictly_increasing) {
        EXPECT_GT(measured, (*levels)[level - 1].measured_error) << "level " << level;
      }
    }

    const fs::path glb = dir / ("lod" + std::to_string(level) + ".glb");
    std::ofstream(glb, std::ios::binary).write(built->glb.data(), static_cast<std::streamsize>(built->glb.size()));
    std::string report;
    EXPECT_EQ(Validate(glb, &report), 0) << glb << "\n" << report.substr(0, 4000);

    // Images are referenced by the shared file names, never embedded.
    tinygltf::Model model;
    tinygltf::TinyGLTF gltf;
    std::string err, warn;
    ASSERT_TRUE(gltf.LoadBinaryFromFile(&model, &err, &warn, glb.string())) << err;
    ASSERT_EQ(model.images.size(), textures.size());
    for (size_t i = 0; i < model.images.size(); ++i) {
      EXPECT_EQ(model.images[i].uri, textures[i]) << "level " << level << " image " << i;
      EXPECT_EQ(model.images[i].bufferView, -1) << "level " << level << " image " << i << " embedded";
    }
    EXPECT_EQ(model.materials.size(), source->model.materials.size());
  }
  fs::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(
    Assets, LodAssetTest,
    ::testing::Values(AssetCase{"DamagedHelmet", "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb", true},
                      AssetCase{"TreeLowPoly", "vegetation/TreeLowPoly_RicardoSanchez/scene.gltf", false},
                      AssetCase{"TransmissionTest", "highpoly/TransmissionTest/glTF-Binary/TransmissionTest.glb", true}),
    [](const auto& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace impostor
