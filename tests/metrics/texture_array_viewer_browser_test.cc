// Texture-array results in the dashboard's viewer: `texture_array`
// (`impostor bake --array`) writes each map as a strip one tile wide with
// layer i = frame i (common/manifest/manifest_format.md). The same bake as an atlas
// and as a texture array must look the same on the result page: the
// orthographic impostor (?ortho) pixel for pixel within one level, the full
// page's impostor canvas covered, and its atlas panel (the layers at their
// frames' tiles, the active frames outlined) like the atlas result's, with
// the same frames marked; the three.js material scene (?scene) draws the
// same impostor.
// Images in build/test_artifacts/dashboard/ (texture_array_*.png).
#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/server_process.h"
#include "tests/metrics/browser_capture.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::ServerProcess;

const fs::path kArtifacts = fs::path(IMPOSTOR_TEST_ARTIFACTS_DIR) / "dashboard";
constexpr int kPixels = 128;
constexpr int kFrames = 8;
constexpr int kResolution = 256;
// Ready, or an error the page reported: a broken page fails at once
// instead of waiting out the driver's deadline.
const char* const kReadyOrFailed =
    "document.body.dataset.viewerReady === '1' || document.getElementById('errors').textContent !== ''";

std::string Submit(ServerProcess& server, const v1::MeshInput& mesh, bool texture_array) {
  v1::SubmitBakeRequest request;
  *request.mutable_mesh() = mesh;
  request.mutable_parameters()->set_layout(v1::LAYOUT_OCTAHEDRAL);
  request.mutable_parameters()->set_frames(kFrames);
  request.mutable_parameters()->set_resolution(kResolution);
  request.mutable_parameters()->set_quality_views(0);
  request.mutable_parameters()->set_texture_array(texture_array);
  v1::SubmitBakeResponse response;
  const grpc::Status s = server.bake().SubmitBake(testing::ContextWithin().get(), request, &response);
  EXPECT_TRUE(s.ok()) << s.error_message();
  return response.job_id();
}

// Largest difference of any channel over two RGBA8 pictures of one size.
int MaxDifference(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
  int worst = 0;
  for (size_t i = 0; i < a.size() && i < b.size(); ++i) worst = std::max(worst, std::abs(a[i] - b[i]));
  return worst;
}

// Pixels whose alpha is at least half.
int Covered(const std::vector<uint8_t>& rgba) {
  int n = 0;
  for (size_t p = 3; p < rgba.size(); p += 4) n += rgba[p] >= 128;
  return n;
}

TEST(TextureArrayViewer, DrawsTheLayerStripAsTheAtlasOfTheSameBake) {
  ASSERT_TRUE(fs::exists("/usr/bin/chromium")) << "chromium is not installed (deploy/install-deps.sh)";
  fs::create_directories(kArtifacts);
  ServerProcess server(/*local_workers=*/1, {"--http-listen=127.0.0.1:0"});
  const std::string line = server.process().ReadLineContaining("http listening on");
  ASSERT_FALSE(line.empty());
  const int port = std::stoi(line.substr(line.rfind(':') + 1));
  const v1::MeshInput mesh =
      testing::UploadGlb(server.assets(), testing::AssetsDir() / "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb");
  const std::string atlas_job = Submit(server, mesh, false);
  const std::string array_job = Submit(server, mesh, true);
  const v1::Job atlas = testing::WatchToEnd(server.bake(), atlas_job);
  const v1::Job array = testing::WatchToEnd(server.bake(), array_job);
  ASSERT_EQ(atlas.state(), v1::JOB_STATE_SUCCEEDED) << atlas.error().message();
  ASSERT_EQ(array.state(), v1::JOB_STATE_SUCCEEDED) << array.error().message();
  const v1::Manifest& m = array.result();
  for (const auto& map : m.maps()) {
    if (map.semantic() != "albedo_alpha") continue;
    ASSERT_EQ(map.width(), m.tile_size()) << "not a layer strip: the case this test is about";
    ASSERT_EQ(map.height(), m.tile_size() * static_cast<uint32_t>(m.views_size()));
  }

  // 1. The orthographic impostor: the same picture from the strip as from the atlas.
  std::vector<uint8_t> pictures[2];
  for (int i = 0; i < 2; ++i) {
    const std::string name = i == 0 ? "atlas" : "array";
    const std::string key = (i == 0 ? atlas : array).result().cache_key();
    const nlohmann::json report =
        testing::RunPage(port, "/results/" + key + "?ortho=35,20&size=" + std::to_string(kPixels) + "&blend=0",
                         kReadyOrFailed, "window.impostorPng || document.getElementById('errors').textContent");
    ASSERT_TRUE(report.value("ok", false)) << name << ": " << report.dump();
    EXPECT_EQ(report.value("console_errors", nlohmann::json::array()), nlohmann::json::array()) << name;
    int w = 0, h = 0;
    pictures[i] = testing::SavePngDataUrl(report.value("value", ""),
                                          kArtifacts / ("texture_array_ortho_" + name + ".png"), &w, &h);
    ASSERT_EQ(w, kPixels) << name;
    ASSERT_EQ(h, kPixels) << name;
  }
  EXPECT_GT(Covered(pictures[0]), kPixels * kPixels / 20) << "the atlas impostor covers almost nothing";
  EXPECT_EQ(Covered(pictures[1]), Covered(pictures[0])) << "images in " << kArtifacts;
  EXPECT_LE(MaxDifference(pictures[0], pictures[1]), 1) << "images in " << kArtifacts;

  // 2. The whole page: the impostor drawn, the atlas panel as the atlas
  // result's (its frames at their tiles, the same frames outlined).
  const std::string page_eval =
      "({errors: document.getElementById('errors').textContent,"
      " marked: window.impostorViewer ? window.impostorViewer.activeFrames() : null,"
      " panel: document.getElementById('atlas').toDataURL('image/png'),"
      " impostor: document.getElementById('impostor').toDataURL('image/png')})";
  nlohmann::json pages[2];
  std::vector<uint8_t> panels[2];
  for (int i = 0; i < 2; ++i) {
    const std::string name = i == 0 ? "atlas" : "array";
    const std::string key = (i == 0 ? atlas : array).result().cache_key();
    const nlohmann::json report = testing::RunPage(port, "/results/" + key + "?camera=35,20,4", kReadyOrFailed,
                                                   page_eval, kArtifacts / ("texture_array_page_" + name + ".png"));
    ASSERT_TRUE(report.value("ok", false)) << name << ": " << report.dump().substr(0, 2000);
    EXPECT_EQ(report.value("console_errors", nlohmann::json::array()), nlohmann::json::array()) << name;
    pages[i] = report["value"];
    ASSERT_EQ(pages[i].value("errors", "?"), "") << name;
    int w = 0, h = 0;
    panels[i] = testing::SavePngDataUrl(pages[i].value("panel", ""),
                                        kArtifacts / ("texture_array_panel_" + name + ".png"), &w, &h);
    const std::vector<uint8_t> impostor = testing::SavePngDataUrl(
        pages[i].value("impostor", ""), kArtifacts / ("texture_array_impostor_" + name + ".png"), &w, &h);
    EXPECT_GT(Covered(impostor), w * h / 20) << name << ": the impostor canvas is (almost) empty";
  }
  EXPECT_EQ(pages[1]["marked"], pages[0]["marked"]) << "the panels mark different frames";
  ASSERT_EQ(panels[0].size(), panels[1].size());
  int differing = 0;
  for (size_t p = 0; p < panels[0].size(); p += 4) {
    int d = 0;
    for (int k = 0; k < 4; ++k) d = std::max(d, std::abs(panels[0][p + k] - panels[1][p + k]));
    differing += d > 8;
  }
  // The panel is scaled with smoothing: a few edge pixels may round apart.
  EXPECT_LE(differing, static_cast<int>(panels[0].size() / 4 / 100))
      << "the texture array's atlas panel differs from the atlas's; images in " << kArtifacts;

  // 3. The three.js material scene: the impostor's mask (white where it
  // draws, no ground) from the strip as from the atlas.
  std::vector<uint8_t> masks[2];
  for (int i = 0; i < 2; ++i) {
    const std::string name = i == 0 ? "atlas" : "array";
    const std::string key = (i == 0 ? atlas : array).result().cache_key();
    const nlohmann::json scene = testing::RunPage(
        port, "/results/" + key + "?scene=35,20,4&size=256", kReadyOrFailed,
        "window.impostorScene ? window.impostorScene.render({object: 'impostor', ground: false, mask: 1})"
        " : document.getElementById('errors').textContent");
    ASSERT_TRUE(scene.value("ok", false)) << name << ": " << scene.dump();
    EXPECT_EQ(scene.value("console_errors", nlohmann::json::array()), nlohmann::json::array()) << name;
    int w = 0, h = 0;
    masks[i] = testing::SavePngDataUrl(scene.value("value", ""),
                                       kArtifacts / ("texture_array_scene_mask_" + name + ".png"), &w, &h);
    ASSERT_FALSE(masks[i].empty()) << name;
  }
  int white = 0;
  for (size_t p = 0; p < masks[0].size(); p += 4) white += masks[0][p] > 127;
  EXPECT_GT(white, static_cast<int>(masks[0].size() / 4 / 20)) << "the atlas impostor's mask is (almost) empty";
  EXPECT_LE(MaxDifference(masks[0], masks[1]), 1) << "images in " << kArtifacts;
}

}  // namespace
}  // namespace impostor
