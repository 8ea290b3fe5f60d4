// The example scene on a Vulkan device (lavapipe is enough), with a real
// bake: DamagedHelmet baked by the worker's pipeline into a result
// directory, read back as the example program reads it, and drawn next to
// (and in place of) the mesh. Checks the figures:
//  - pixel depth offset: where the impostor crosses the ground plane, the
//    visible boundary (object in front of the ground or not) matches the
//    mesh's within 2 px at 512 px; a flat card without the offset does not;
//  - shadow: the impostor's shadow on the ground covers the mesh's
//    (IoU >= 0.9), seen from the camera;
//  - lit impostor vs lit mesh: PSNR printed;
//  - bad result directories: clear errors.
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "common/atlas/atlas_layout.h"
#include "common/request/bake_request.h"
#include "examples/impostor_scene/baked_impostor.h"
#include "examples/impostor_scene/scene_renderer.h"
#include "worker/bake/atlas_bake.h"
#include "worker/gpu/atlas_renderer.h"
#include "worker/output/map_writer.h"
#include "worker/scene/gltf_loader.h"
#include "tests/support/boundary_mismatch.h"

namespace impostor::example {
namespace {

namespace fs = std::filesystem;

constexpr int kPixels = 512;
// Crossing pixels allowed more than 2 px off (the rest of the boundary must
// be within 2 px).
constexpr int kAllowedFar = 0;
const fs::path kHelmet =
    fs::path(IMPOSTOR_TEST_ASSETS_DIR) / "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb";

fs::path ScratchDir(const std::string& tag) {
  const fs::path dir = fs::temp_directory_path() / ("impostor_scene_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

class ImpostorSceneTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    result_dir_ = new fs::path(ScratchDir("result"));
    auto renderer = AtlasRenderer::Create();
    if (!renderer.ok()) {
      error_ = new std::string("no Vulkan device: " + renderer.status().ToString());
      return;
    }
    v1::BakeParameters in;
    in.set_layout(v1::LAYOUT_OCTAHEDRAL);
    in.set_frames(12);
    in.set_resolution(2048);
    in.set_quality_views(0);
    auto params = NormalizeParameters(in);
    if (!params.ok()) {
      error_ = new std::string(params.status().ToString());
      return;
    }
    const std::atomic<bool> cancelled{false};
    const AtlasBakeRequest request{
        .entry_file = kHelmet, .parameters = *params, .cache_key = "scene-test", .output_dir = *result_dir_};
    auto baked = BakeAtlas(request, **renderer, [](std::string_view, double) {}, cancelled);
    if (!baked.ok()) {
      error_ = new std::string("bake: " + baked.status().ToString());
      return;
    }
    auto impostor = LoadBakedImpostor(*result_dir_);
    auto mesh = LoadGltfScene(kHelmet);
    auto scene = SceneRenderer::Create("");
    if (!impostor.ok() || !mesh.ok() || !scene.ok()) {
      error_ = new std::string("load: " + impostor.status().ToString() + " / " + mesh.status().ToString() + " / " +
                               scene.status().ToString());
      return;
    }
    impostor_ = new BakedImpostor(std::move(*impostor));
    mesh_ = new Scene(std::move(*mesh));
    scene_ = scene->release();
  }
  static void TearDownTestSuite() {
    delete scene_;
    delete mesh_;
    delete impostor_;
    if (result_dir_ != nullptr) fs::remove_all(*result_dir_);
    delete result_dir_;
    delete error_;
  }
  void SetUp() override {
    // A gpu-labelled test fails without a device: `ctest -LE gpu` opts out.
    ASSERT_EQ(error_, nullptr) << *error_;
  }

  // Mesh or impostor alone, both at the scene-space placement, 512 px.
  static SceneSetup Alone(bool mesh, bool ground) {
    SceneSetup s = DefaultSetup(impostor_->sphere_center, impostor_->sphere_radius, /*side_by_side=*/false);
    s.width = s.height = kPixels;
    s.draw_mesh = mesh;
    s.draw_impostor = !mesh;
    s.draw_ground = ground;
    return s;
  }
  static SceneImage Render(const SceneSetup& s) {
    auto image = scene_->Render(*mesh_, *impostor_, s);
    EXPECT_TRUE(image.ok()) << image.status();
    return image.ok() ? std::move(*image) : SceneImage{};
  }

  static inline fs::path* result_dir_ = nullptr;
  static inline std::string* error_ = nullptr;
  static inline BakedImpostor* impostor_ = nullptr;
  static inline Scene* mesh_ = nullptr;
  static inline SceneRenderer* scene_ = nullptr;
};

std::vector<uint8_t> ObjectMask(const SceneImage& image) {
  std::vector<uint8_t> mask(image.rgba.size() / 4);
  for (size_t i = 0; i < mask.size(); ++i) mask[i] = image.rgba[i * 4 + 3] >= 128;
  return mask;
}

// The camera moved onto the baked frame nearest to the default view (same
// distance), the ground a little higher so it cuts more of the helmet: the
// depth offset is then the frame's own depth (between frames it is a blend,
// measured by the lit and shadow figures instead).
SceneSetup AtFrameView(SceneSetup s, glm::vec3 center, float radius) {
  const ViewLayout layout{LayoutKind::kOctahedral, 12, 0};
  const glm::vec3 want = glm::normalize(s.eye - center);
  glm::vec3 best = want;
  float best_dot = -2.0f;
  for (int i = 0; i < FrameCount(layout); ++i) {
    const glm::vec3 d = FrameDirectionAt(layout, i);
    if (glm::dot(d, want) > best_dot) best_dot = glm::dot(d, want), best = d;
  }
  s.eye = center + best * glm::length(s.eye - center);
  s.ground_height = center.y - 0.3f * radius;
  return s;
}

TEST_F(ImpostorSceneTest, DepthOffsetPutsTheGroundCrossingWhereTheMeshHasIt) {
  const glm::vec3 c = impostor_->sphere_center;
  const float r = impostor_->sphere_radius;
  const std::vector<uint8_t> mesh_front = ObjectMask(Render(AtFrameView(Alone(true, true), c, r)));
  const std::vector<uint8_t> mesh_covered = ObjectMask(Render(AtFrameView(Alone(true, false), c, r)));
  const std::vector<uint8_t> imp_front = ObjectMask(Render(AtFrameView(Alone(false, true), c, r)));
  const std::vector<uint8_t> imp_covered = ObjectMask(Render(AtFrameView(Alone(false, false), c, r)));
  SceneSetup flat = AtFrameView(Alone(false, true), c, r);
  flat.depth_offset = false;
  const std::vector<uint8_t> card_front = ObjectMask(Render(flat));
  ASSERT_EQ(mesh_front.size(), static_cast<size_t>(kPixels) * kPixels);
  std::vector<uint8_t> both(mesh_front.size());
  int crossing = 0, covered = 0;
  for (size_t i = 0; i < both.size(); ++i) {
    both[i] = mesh_covered[i] && imp_covered[i];
    covered += both[i];
    crossing += both[i] && !mesh_front[i];  // the object is there, the ground hides it
  }
  const int far = testing::FarMismatches(imp_front, mesh_front, both, kPixels, 2);
  const int card_far = testing::FarMismatches(card_front, mesh_front, both, kPixels, 2);
  std::printf("[ figures  ] %d object pixels, %d behind the ground; the impostor's ground crossing is off by > 2 px "
              "at %d pixels with the depth offset, %d as a flat card\n",
              covered, crossing, far, card_far);
  ASSERT_GT(crossing, 1000) << "the ground must cut through the helmet";
  EXPECT_LE(far, kAllowedFar) << "pixels where the impostor's ground crossing is more than 2 px from the mesh's";
  EXPECT_GT(card_far, 1000) << "without the offset the crossing must be wrong (the test can fail)";
}

TEST_F(ImpostorSceneTest, ImpostorShadowCoversTheMeshShadowAndLitPsnrIsReported) {
  SceneSetup empty = Alone(true, true);
  empty.draw_mesh = false;
  const SceneImage ground = Render(empty);  // unshadowed ground
  const SceneImage mesh = Render(Alone(true, true));
  const SceneImage imp = Render(Alone(false, true));
  ASSERT_EQ(ground.rgba.size(), mesh.rgba.size());
  ASSERT_EQ(imp.rgba.size(), mesh.rgba.size());
  // A ground pixel is in shadow where it is darker than the open ground by
  // more than half the way to ambient only (the 3x3 filter blurs the edge).
  int inter = 0, uni = 0, ground_pixels = 0;
  for (size_t i = 0; i < ground.rgba.size() / 4; ++i) {
    const uint8_t* g = &ground.rgba[i * 4];
    const uint8_t* m = &mesh.rgba[i * 4];
    const uint8_t* p = &imp.rgba[i * 4];
    const bool is_ground = g[0] != ground.rgba[0] || g[1] != ground.rgba[1] || g[2] != ground.rgba[2];
    if (!is_ground || m[3] >= 128 || p[3] >= 128) continue;  // sky, or hidden by either object
    ++ground_pixels;
    const bool mesh_shadow = m[1] < 0.77f * g[1];
    const bool imp_shadow = p[1] < 0.77f * g[1];
    inter += mesh_shadow && imp_shadow;
    uni += mesh_shadow || imp_shadow;
  }
  ASSERT_GT(ground_pixels, 10000) << "the top-left pixel must be sky and the ground in view";
  ASSERT_GT(uni, 1000) << "the shadows must fall in view";
  const double iou = static_cast<double>(inter) / uni;
  std::printf("[ figures  ] shadow on the ground seen from the camera, impostor vs mesh: IoU %.4f (%d | %d px)\n",
              iou, inter, uni);
  RecordProperty("shadow_iou", std::to_string(iou));
  EXPECT_GE(iou, 0.9);

  // Lit impostor vs lit mesh, no ground, over the pixels either covers.
  const SceneImage lit_mesh = Render(Alone(true, false));
  const SceneImage lit_imp = Render(Alone(false, false));
  double se = 0.0;
  size_t n = 0;
  for (size_t i = 0; i < lit_mesh.rgba.size() / 4; ++i) {
    if (lit_mesh.rgba[i * 4 + 3] < 128 && lit_imp.rgba[i * 4 + 3] < 128) continue;
    for (int k = 0; k < 3; ++k) {
      const double d = (lit_mesh.rgba[i * 4 + k] - lit_imp.rgba[i * 4 + k]) / 255.0;
      se += d * d / 3.0;
    }
    ++n;
  }
  ASSERT_GT(n, 10000u);
  const double psnr = 10.0 * std::log10(1.0 / std::max(se / n, 1e-12));
  std::printf("[ figures  ] lit impostor vs lit mesh (sRGB, 512 px, view between frames): PSNR %.2f dB over %zu "
              "pixels\n",
              psnr, n);
  RecordProperty("lit_psnr_db", std::to_string(psnr));
  // Measured 20.05 dB (parallax on; 13.5 dB without). A lighting mismatch
  // (normals in the wrong space, a missing shadow) costs far more.
  EXPECT_GT(psnr, 17.0) << "the impostor must be lit like the mesh";
}

TEST_F(ImpostorSceneTest, SideBySideSceneShowsBothAndWritesAPng) {
  SceneSetup s = DefaultSetup(impostor_->sphere_center, impostor_->sphere_radius, /*side_by_side=*/true);
  const SceneImage image = Render(s);
  ASSERT_EQ(image.rgba.size(), static_cast<size_t>(s.width) * s.height * 4);
  int left = 0, right = 0;
  for (int y = 0; y < s.height; ++y) {
    for (int x = 0; x < s.width; ++x) {
      if (image.rgba[(static_cast<size_t>(y) * s.width + x) * 4 + 3] < 128) continue;
      (x < s.width / 2 ? left : right)++;
    }
  }
  std::printf("[ figures  ] side by side: mesh %d px, impostor %d px\n", left, right);
  EXPECT_GT(left, 5000);
  EXPECT_GT(right, 5000);
  EXPECT_LT(std::abs(left - right), (left + right) / 10) << "the impostor is as large as the mesh";
  const fs::path png = *result_dir_ / "scene.png";
  ASSERT_TRUE(WritePngRgba8(png, image.rgba, image.width, image.height).ok());
  auto back = ReadPng(png);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->pixels8, image.rgba);
}

// A copy of the baked result with its manifest edited by `edit`.
fs::path EditedResult(const fs::path& from, const std::string& tag, const std::function<void(nlohmann::json&)>& edit) {
  const fs::path dir = ScratchDir(tag);
  for (const auto& entry : fs::directory_iterator(from)) {
    if (entry.path().extension() == ".png") fs::copy_file(entry.path(), dir / entry.path().filename());
  }
  std::ifstream in(from / "manifest.json");
  nlohmann::json manifest = nlohmann::json::parse(in);
  edit(manifest);
  std::ofstream(dir / "manifest.json") << manifest.dump(2);
  return dir;
}

TEST_F(ImpostorSceneTest, BadResultDirectoriesGiveClearErrors) {
  auto missing = LoadBakedImpostor("/nonexistent/impostor/result");
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(missing.status().message().find("/nonexistent/impostor/result"), std::string::npos) << missing.status();

  const fs::path no_manifest = ScratchDir("empty");
  auto empty = LoadBakedImpostor(no_manifest);
  EXPECT_EQ(empty.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(empty.status().message().find("manifest.json"), std::string::npos) << empty.status();

  struct Case {
    const char* tag;
    std::function<void(nlohmann::json&)> edit;
    absl::StatusCode code;
    const char* says;
  };
  const Case cases[] = {
      {"views", [](nlohmann::json& m) { m["views"].erase(m["views"].begin()); }, absl::StatusCode::kInvalidArgument,
       "frames x frames views"},
      {"billboard", [](nlohmann::json& m) { m["layout"] = "billboard"; }, absl::StatusCode::kInvalidArgument,
       "billboard needs 9 views"},
      {"ktx2",
       [](nlohmann::json& m) {
         for (auto& map : m["maps"])
           if (map["semantic"] == "normal_depth") map["format"] = "ktx2_uastc";
       },
       absl::StatusCode::kInvalidArgument, "--texture-format png"},
      {"resolution", [](nlohmann::json& m) { m["resolution"] = 1024; }, absl::StatusCode::kInvalidArgument,
       "resolution is 1024"},
      {"no_orm",
       [](nlohmann::json& m) {
         auto& maps = m["maps"];
         for (auto it = maps.begin(); it != maps.end(); ++it)
           if ((*it)["semantic"] == "orm") {
             maps.erase(it);
             break;
           }
       },
       absl::StatusCode::kNotFound, "no 'orm' map"},
  };
  for (const Case& c : cases) {
    const fs::path dir = EditedResult(*result_dir_, c.tag, c.edit);
    auto loaded = LoadBakedImpostor(dir);
    EXPECT_EQ(loaded.status().code(), c.code) << c.tag << ": " << loaded.status();
    EXPECT_NE(loaded.status().message().find(c.says), std::string::npos) << c.tag << ": " << loaded.status();
    fs::remove_all(dir);
  }
  fs::remove_all(no_manifest);

  SceneSetup tiny = Alone(true, true);
  tiny.width = 8;
  auto image = scene_->Render(*mesh_, *impostor_, tiny);
  EXPECT_EQ(image.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(image.status().message().find("16..4096"), std::string::npos) << image.status();
}

}  // namespace
}  // namespace impostor::example
