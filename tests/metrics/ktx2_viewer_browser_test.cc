// KTX2 results in the dashboard's viewer (issue 22): the same bake as PNG
// and as KTX2 (`texture_format: ktx2`, Basis Universal UASTC) drawn by the
// viewer's WebGL2 impostor (web/impostor_gl.js, which decodes KTX2 maps
// with three.js's KTX2Loader and the Basis transcoder three ships:
// web/ktx2_rgba.js) for the same orthographic camera in headless
// Chromium. The KTX2 picture matches the PNG one within the compression's
// error: silhouette IoU >= 0.98 and albedo PSNR >= 30 dB over the shared
// silhouette. The full viewer page and the three.js material scene load
// the KTX2 result without a console error. Images in
// build/test_artifacts/dashboard/ (ktx2_viewer_*.png).
#include <cmath>
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
constexpr double kMinPsnrDb = 30;

std::string Submit(ServerProcess& server, const v1::MeshInput& mesh, v1::TextureFormat format) {
  v1::SubmitBakeRequest request;
  *request.mutable_mesh() = mesh;
  request.mutable_parameters()->set_layout(v1::LAYOUT_OCTAHEDRAL);
  request.mutable_parameters()->set_frames(8);
  request.mutable_parameters()->set_resolution(256);
  request.mutable_parameters()->set_quality_views(0);
  request.mutable_parameters()->set_texture_format(format);
  v1::SubmitBakeResponse response;
  const grpc::Status s = server.bake().SubmitBake(testing::ContextWithin().get(), request, &response);
  EXPECT_TRUE(s.ok()) << s.error_message();
  return response.job_id();
}

// The viewer's orthographic impostor at azimuth 35, elevation 20 (RGBA8).
std::vector<uint8_t> ViewerPicture(int port, const std::string& key, const std::string& name) {
  const nlohmann::json report =
      testing::RunPage(port, "/results/" + key + "?ortho=35,20&size=" + std::to_string(kPixels) + "&blend=0",
                       "document.body.dataset.viewerReady === '1'", "window.impostorPng");
  EXPECT_TRUE(report.value("ok", false)) << report.dump();
  EXPECT_EQ(report.value("console_errors", nlohmann::json::array()), nlohmann::json::array()) << report.dump();
  int w = 0, h = 0;
  std::vector<uint8_t> pixels =
      testing::SavePngDataUrl(report.value("value", ""), kArtifacts / ("ktx2_viewer_" + name + ".png"), &w, &h);
  EXPECT_EQ(w, kPixels);
  EXPECT_EQ(h, kPixels);
  return pixels;
}

TEST(Ktx2Viewer, DrawsAKtx2ResultAsThePngResultWithinTheCompressionError) {
  ASSERT_TRUE(fs::exists("/usr/bin/chromium")) << "chromium is not installed (deploy/install-deps.sh)";
  fs::create_directories(kArtifacts);
  ServerProcess server(/*local_workers=*/1, {"--http-listen=127.0.0.1:0"});
  const std::string line = server.process().ReadLineContaining("http listening on");
  ASSERT_FALSE(line.empty());
  const int port = std::stoi(line.substr(line.rfind(':') + 1));
  const v1::MeshInput mesh =
      testing::UploadGlb(server.assets(), testing::AssetsDir() / "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb");
  const std::string png_job = Submit(server, mesh, v1::TEXTURE_FORMAT_PNG);
  const std::string ktx2_job = Submit(server, mesh, v1::TEXTURE_FORMAT_KTX2);
  const v1::Job png = testing::WatchToEnd(server.bake(), png_job);
  const v1::Job ktx2 = testing::WatchToEnd(server.bake(), ktx2_job);
  ASSERT_EQ(png.state(), v1::JOB_STATE_SUCCEEDED) << png.error().message();
  ASSERT_EQ(ktx2.state(), v1::JOB_STATE_SUCCEEDED) << ktx2.error().message();
  int ktx2_maps = 0;
  for (const auto& map : ktx2.result().maps()) ktx2_maps += map.file().ends_with(".ktx2");
  ASSERT_GE(ktx2_maps, 2) << "the KTX2 bake wrote no .ktx2 maps";

  const std::vector<uint8_t> reference = ViewerPicture(port, png.result().cache_key(), "png");
  const std::vector<uint8_t> picture = ViewerPicture(port, ktx2.result().cache_key(), "ktx2");
  ASSERT_EQ(reference.size(), picture.size());
  ASSERT_FALSE(picture.empty());
  int both = 0, either = 0;
  double squared_error = 0;
  for (size_t p = 0; p < picture.size(); p += 4) {
    const bool a = picture[p + 3] >= 128, b = reference[p + 3] >= 128;
    either += a || b;
    if (!(a && b)) continue;
    ++both;
    for (int k = 0; k < 3; ++k) {
      const double d = (picture[p + k] - reference[p + k]) / 255.0;
      squared_error += d * d;
    }
  }
  ASSERT_GT(either, kPixels * kPixels / 20) << "the impostor covers almost nothing";
  const double iou = static_cast<double>(both) / either;
  const double mse = squared_error / (3.0 * std::max(both, 1));
  const double psnr = mse > 0 ? 10 * std::log10(1.0 / mse) : 99;
  EXPECT_GE(iou, 0.98) << "images in " << kArtifacts;
  EXPECT_GE(psnr, kMinPsnrDb) << "images in " << kArtifacts;
  std::printf("KTX2 vs PNG in the viewer: IoU %.4f, albedo PSNR %.2f dB over the shared silhouette\n", iou, psnr);

  // The whole viewer page (mesh | impostor, debug views) and the three.js
  // material scene load the KTX2 result.
  for (const std::string query : {"?camera=35,20,4", "?scene=35,20,4&size=256"}) {
    const nlohmann::json page =
        testing::RunPage(port, "/results/" + ktx2.result().cache_key() + query,
                         "document.body.dataset.viewerReady === '1'", "document.getElementById('errors').textContent");
    EXPECT_TRUE(page.value("ok", false)) << query << ": " << page.dump();
    EXPECT_EQ(page.value("console_errors", nlohmann::json::array()), nlohmann::json::array()) << query;
    EXPECT_EQ(page.value("value", std::string("?")), "") << query << ": the page reported an error";
  }
}

}  // namespace
}  // namespace impostor
