// The surfel cloud bake through the real Vulkan renderer (Mesa lavapipe
// suffices): budgets, geometry against the triangles, colours in linear
// space, the quality pass, and the files a bake writes.
#include "tests/gpu/shared_renderer_test.h"
#include "worker/bake/surfel_bake.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "common/request/bake_request.h"
#include "common/manifest/manifest_json.h"
#include "common/util/sha256.h"
#include "tests/surfels/mesh_distance.h"
#include "worker/scene/gltf_loader.h"
#include "worker/surfels/atlas_samples.h"
#include "worker/surfels/ply_writer.h"
#include "worker/surfels/point_buffer.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

class SurfelBakeTest : public testing::SharedRendererTest {
 protected:

  static v1::BakeParameters Params(const std::string& preset, uint32_t budget = 0, uint32_t frames = 0,
                                   uint32_t resolution = 0, v1::Layout layout = v1::LAYOUT_UNSPECIFIED) {
    v1::BakeParameters in;
    in.set_product(v1::PRODUCT_SURFELS);
    in.set_preset(preset);
    if (budget != 0) in.set_point_budget(budget);
    in.set_frames(frames);
    in.set_resolution(resolution);
    in.set_layout(layout);
    auto p = NormalizeParameters(in);
    EXPECT_TRUE(p.ok()) << p.status();
    return *p;
  }

  static absl::StatusOr<SurfelCloudResult> Bake(const Scene& scene, const v1::BakeParameters& p) {
    const std::atomic<bool> cancelled{false};
    return BakeSurfelCloud(scene, p, *renderer_, [](std::string_view, double) {}, cancelled);
  }

};

// The step between the 8-bit sRGB codes around a linear value, in linear
// units: the precision the capture keeps of a base colour.
float OneSrgbCode(float linear) {
  const uint8_t code = LinearToSrgbByte(linear);
  return SrgbByteToLinear(code == 255 ? 255 : code + 1) - SrgbByteToLinear(code == 255 ? 254 : code) + 1e-6f;
}

// Every invariant of a cloud of a closed mesh.
void ExpectSoundCloud(const Scene& scene, const SurfelCloudResult& cloud, uint32_t budget) {
  EXPECT_LE(cloud.points.size(), budget);
  EXPECT_GE(static_cast<double>(cloud.points.size()), 0.9 * budget) << "a sphere has enough surface";
  EXPECT_NEAR(cloud.point_diameter, cloud.voxel_size * std::sqrt(2.0f), 1e-6f);
  float worst_surface = 0, worst_sphere = 0;
  for (const Surfel& p : cloud.points) {
    ASSERT_NEAR(glm::length(p.normal), 1.0f, 1e-4f);
    worst_sphere = std::max(worst_sphere, glm::length(p.position - cloud.sphere.center) - cloud.sphere.radius);
    worst_surface = std::max(worst_surface, testing::DistanceToMesh(scene, p.position));
  }
  EXPECT_LE(worst_sphere, 1e-4f * cloud.sphere.radius) << "every point inside the bounding sphere";
  EXPECT_LE(worst_surface, cloud.voxel_size) << "every point within one voxel of the triangles";
  std::printf("[ figures  ] samples %zu points %zu / %u (fill %.4f) voxel %.5f evaluations %d worst distance %.5f "
              "(%.2f voxel) iou mean %.4f min %.4f (%d px) albedo PSNR %.2f dB, cluster %.2f s quality %.2f s\n",
              cloud.sample_count, cloud.points.size(), budget, static_cast<double>(cloud.points.size()) / budget,
              cloud.voxel_size, cloud.fit.evaluations, worst_surface, worst_surface / cloud.voxel_size,
              cloud.quality.iou_mean, cloud.quality.iou_min, cloud.quality.view_pixels, cloud.quality.albedo_psnr_db,
              cloud.cluster_seconds, cloud.quality_seconds);
}

TEST_F(SurfelBakeTest, PropPresetOnASphereFillsTheBudgetOnTheSurfaceInLinearColour) {
  const glm::vec4 base(0.5f, 0.2f, 0.05f, 1.0f);  // linear, as glTF's baseColorFactor
  const Scene scene = testing::SphereScene({0.3f, -1.0f, 2.0f}, 1.5f, 24, base, 0.6f, 0.0f);
  const v1::BakeParameters p = Params("prop");
  auto cloud = Bake(scene, p);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  ExpectSoundCloud(scene, *cloud, 2048);
  for (const Surfel& s : cloud->points) {
    // The capture stores 8-bit sRGB: within one code of the linear factor.
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(s.albedo[c], base[c], OneSrgbCode(base[c])) << "channel " << c;
    ASSERT_NEAR(s.orm.x, 1.0f, 1.0f / 255);
    ASSERT_NEAR(s.orm.y, 0.6f, 1.0f / 255);
    ASSERT_NEAR(s.orm.z, 0.0f, 1.0f / 255);
    ASSERT_GT(glm::dot(s.normal, glm::normalize(s.position - glm::vec3(0.3f, -1.0f, 2.0f))), 0.9f)
        << "outward normals";
  }
  EXPECT_GT(cloud->quality.iou_mean, 0.85);
  EXPECT_GT(cloud->quality.albedo_psnr_db, 40.0) << "a flat colour";
}

TEST_F(SurfelBakeTest, ExplicitBudgetsOnANonPowerOfTwoCaptureAreFilledNotExceeded) {
  const Scene scene = testing::SphereScene({0, 0, 0}, 1.0f, 32, {0.8f, 0.8f, 0.8f, 1.0f}, 1.0f, 0.0f);
  for (uint32_t budget : {500u, 6000u}) {
    SCOPED_TRACE(::testing::Message() << "budget " << budget);
    auto cloud = Bake(scene, Params("building", budget, /*frames=*/10, /*resolution=*/1000));
    ASSERT_TRUE(cloud.ok()) << cloud.status();
    ExpectSoundCloud(scene, *cloud, budget);
  }
}

TEST_F(SurfelBakeTest, ABudgetTheCaptureCannotReachIsReportedNotFaked) {
  const Scene scene = testing::SphereScene({0, 0, 0}, 1.0f, 16, {0.8f, 0.8f, 0.8f, 1.0f}, 1.0f, 0.0f);
  auto cloud = Bake(scene, Params("prop", /*budget=*/4'000'000, /*frames=*/3, /*resolution=*/64));
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  EXPECT_FALSE(cloud->fit.budget_reached);
  EXPECT_LT(cloud->points.size(), cloud->sample_count + 1);
  EXPECT_LT(cloud->points.size(), 4'000'000u);
}

TEST_F(SurfelBakeTest, BakeSurfelsWritesBufferPlyAndManifestOfAFlatColouredBox) {
  const fs::path box = fs::path(IMPOSTOR_TEST_ASSETS_DIR) / "props_pbr/Box/glTF-Binary/Box.glb";
  const fs::path out = fs::temp_directory_path() / ("surfel_bake_" + std::to_string(::getpid()));
  fs::remove_all(out);
  fs::create_directories(out);
  AtlasBakeRequest request{.entry_file = box,
                           .parameters = Params("prop", /*budget=*/1000),
                           .cache_key = std::string(64, 'f'),
                           .output_dir = out};
  const std::atomic<bool> cancelled{false};
  auto baked = BakeSurfels(request, *renderer_, [](std::string_view, double) {}, cancelled);
  ASSERT_TRUE(baked.ok()) << baked.status();
  const v1::Manifest& m = baked->manifest;
  EXPECT_EQ(m.product(), v1::PRODUCT_SURFELS);
  ASSERT_EQ(m.maps_size(), 2);
  EXPECT_EQ(m.maps(0).semantic(), "surfels");
  EXPECT_EQ(m.maps(1).semantic(), "surfels_ply");
  for (const auto& map : m.maps()) {
    auto d = DigestFile(out / map.file());
    ASSERT_TRUE(d.ok()) << map.file();
    EXPECT_EQ(d->hash, map.digest().hash()) << map.file();
  }
  const v1::SurfelCloud& s = m.surfels();
  EXPECT_LE(s.point_count(), 1000u);
  EXPECT_GE(s.point_count(), 900u);
  EXPECT_EQ(s.point_budget(), 1000u);
  EXPECT_NEAR(s.budget_fill(), s.point_count() / 1000.0f, 1e-6f);
  EXPECT_EQ(s.digest().hash(), m.maps(0).digest().hash());
  EXPECT_EQ(s.capture_frames(), 12u);
  EXPECT_EQ(s.capture_resolution(), 512u);

  std::ifstream in(out / s.file(), std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto points = DecodePointBuffer(bytes);
  ASSERT_TRUE(points.ok()) << points.status();
  ASSERT_EQ(points->size(), s.point_count());
  auto scene = LoadGltfScene(box);
  ASSERT_TRUE(scene.ok()) << scene.status();
  // Box.glb's only material: baseColorFactor (0.8, 0, 0), metallic 0.
  ASSERT_EQ(scene->materials.size(), 1u);
  const glm::vec4 base = scene->materials[0].base_color_factor;
  for (const Surfel& p : *points) {
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(p.albedo[c], base[c], OneSrgbCode(base[c])) << "channel " << c;
    ASSERT_LE(testing::DistanceToMesh(*scene, p.position), s.voxel_size());
    for (int a = 0; a < 3; ++a) {
      ASSERT_GE(p.position[a], s.bounds_min(a));
      ASSERT_LE(p.position[a], s.bounds_max(a));
    }
  }

  std::ifstream json_in(baked->manifest_path);
  std::stringstream json;
  json << json_in.rdbuf();
  auto from_disk = ManifestFromJson(json.str());
  ASSERT_TRUE(from_disk.ok()) << from_disk.status();
  EXPECT_EQ(from_disk->surfels().point_count(), s.point_count());
  EXPECT_FLOAT_EQ(from_disk->surfels().point_diameter(), s.point_diameter());
  std::ifstream ply(out / s.ply_file(), std::ios::binary);
  std::string line;
  bool declared = false;
  while (std::getline(ply, line) && line != "end_header") {
    declared = declared || line == "element vertex " + std::to_string(s.point_count());
  }
  EXPECT_TRUE(declared);
  fs::remove_all(out);
}

TEST_F(SurfelBakeTest, AMeshCutAwayEntirelyByAlphaIsRefusedClearly) {
  Scene scene = testing::SphereScene({0, 0, 0}, 1.0f, 8, {1.0f, 1.0f, 1.0f, 0.0f}, 1.0f, 0.0f);
  scene.materials[0].alpha_mode = AlphaMode::kMask;
  auto cloud = Bake(scene, Params("prop"));
  ASSERT_FALSE(cloud.ok());
  EXPECT_EQ(cloud.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(cloud.status().message().find("no texel"), std::string::npos) << cloud.status();
}

}  // namespace
}  // namespace impostor
