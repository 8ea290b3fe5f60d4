// The dashboard's WebGL2 impostor (the impostor-three package's ImpostorMesh running
// shaders/impostor_runtime.glsl in headless Chromium on SwiftShader) against
// the CPU reference renderer (common/runtime/reference_renderer.h) for the
// same orthographic camera, for every layout: silhouette IoU >= 0.98 and
// albedo PSNR >= 30 dB over the shared silhouette (the floor; they
// measure 78-84 dB, at most 1 level apart) and under 1% of shared pixels off
// by more than 16 levels (a one-sided rim at the silhouette is how a
// straight/premultiplied alpha mix-up shows). Both images are kept in
// build/test_artifacts/dashboard/ (webgl_LAYOUT.png, reference_LAYOUT.png).
#include <cmath>
#include <filesystem>
#include <fstream>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "common/atlas/frame_camera.h"
#include "common/runtime/reference_renderer.h"
#include "tests/support/server_process.h"
#include "tests/metrics/browser_capture.h"

#include <httplib.h>

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::ReadRgba;
using testing::ServerProcess;

const fs::path kArtifacts = fs::path(IMPOSTOR_TEST_ARTIFACTS_DIR) / "dashboard";
constexpr int kPixels = 128;
constexpr double kAzimuthDeg = 35, kElevationDeg = 20;

void WriteRgba8(const fs::path& file, const std::vector<uint8_t>& pixels, int width, int height) {
  auto out = OIIO::ImageOutput::create(file.string());
  if (!out) return;
  OIIO::ImageSpec spec(width, height, 4, OIIO::TypeDesc::UINT8);
  spec.attribute("oiio:UnassociatedAlpha", 1);  // keep RGB as given (no division by A)
  out->open(file.string(), spec);
  out->write_image(OIIO::TypeDesc::UINT8, pixels.data());
  out->close();
}

constexpr double kMinPsnrDb = 30;        // the floor, every layout
constexpr double kMaxLargeFraction = 0.01;  // of shared pixels off by > 16 levels

TEST(WebGlImpostor, MatchesTheCpuReferenceRendererForEveryLayout) {
  ASSERT_TRUE(fs::exists("/usr/bin/chromium")) << "chromium is not installed (deploy/install-deps.sh)";
  fs::create_directories(kArtifacts);
  ServerProcess server(/*local_workers=*/1, {"--http-listen=127.0.0.1:0"});
  const std::string line = server.process().ReadLineContaining("http listening on");
  ASSERT_FALSE(line.empty());
  const int port = std::stoi(line.substr(line.rfind(':') + 1));
  httplib::Client http("127.0.0.1", port);
  http.set_read_timeout(60, 0);
  const v1::MeshInput mesh =
      testing::UploadGlb(server.assets(), testing::AssetsDir() / "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb");

  const std::vector<std::string> jobs = testing::SubmitEveryLayout(server, mesh);
  ASSERT_EQ(jobs.size(), std::size(testing::kEveryLayout));

  const double az = kAzimuthDeg * M_PI / 180, el = kElevationDeg * M_PI / 180;
  const glm::vec3 direction(std::sin(az) * std::cos(el), std::sin(el), std::cos(az) * std::cos(el));
  for (size_t i = 0; i < jobs.size(); ++i) {
    const testing::LayoutCase& c = testing::kEveryLayout[i];
    SCOPED_TRACE(c.name);
    const v1::Job done = testing::WatchToEnd(server.bake(), jobs[i]);
    ASSERT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
    const v1::Manifest& m = done.result();

    // The reference: the result's maps through the CPU renderer.
    ImpostorAtlas atlas;
    atlas.layout = c.kind;
    atlas.frames = static_cast<int>(m.frames());
    atlas.ring_views = testing::RingViews(c.kind, m);
    atlas.resolution = static_cast<int>(m.resolution());
    atlas.sphere.center = {m.bounding_sphere().center(0), m.bounding_sphere().center(1), m.bounding_sphere().center(2)};
    atlas.sphere.radius = m.bounding_sphere().radius();
    atlas.cameras = AtlasCameras(AtlasViewLayout(atlas), atlas.resolution);
    for (const auto& map : m.maps()) {
      if (map.semantic() != "albedo_alpha" && map.semantic() != "normal_depth") continue;
      auto res = http.Get(("/api/v1/results/" + m.cache_key() + "/files/" + map.file()).c_str());
      ASSERT_TRUE(res && res->status == 200) << map.file();
      const fs::path file = testing::NewTempDir("webgl_ref") / map.file();
      std::ofstream(file, std::ios::binary) << res->body;
      if (map.semantic() == "albedo_alpha") {
        atlas.albedo_alpha = ReadRgba<uint8_t>(file, &atlas.width, &atlas.height);
      } else {
        atlas.normal_depth = ReadRgba<uint16_t>(file, &atlas.width, &atlas.height);
      }
    }
    const FrameCamera camera = ViewCameraFor(direction);
    // Both reconstructions of docs/runtime.md: plain (the viewer's default)
    // and depth.
    for (Reconstruction mode : {Reconstruction::kPlain, Reconstruction::kDepth}) {
      const std::string name = std::string(c.name) + (mode == Reconstruction::kDepth ? "_depth" : "");
      ReferenceRenderOptions options;
      options.reconstruction = mode;
      const ViewImages reference = RenderImpostorView(atlas, camera, kPixels, options);
      ASSERT_EQ(reference.width, kPixels) << "reference renderer refused the atlas";
      WriteRgba8(kArtifacts / ("reference_" + name + ".png"), reference.albedo_alpha, kPixels, kPixels);

      // The browser: the same camera through the dashboard's WebGL2 path.
      const testing::ToolRun run = testing::RunTool(
          {"/usr/bin/node", "--experimental-websocket",
           std::string(IMPOSTOR_SOURCE_DIR) + "/tests/metrics/browser/cdp_page.mjs", "--chromium", "/usr/bin/chromium",
           "--url",
           "http://127.0.0.1:" + std::to_string(port) + "/results/" + m.cache_key() + "?ortho=" +
               std::to_string(kAzimuthDeg) + "," + std::to_string(kElevationDeg) + "&size=" + std::to_string(kPixels) + "&blend=0&reconstruction=" + std::string(ReconstructionName(mode)),  // triangle3, the reference's default
           "--until", "document.body.dataset.viewerReady === '1'", "--eval", "window.impostorPng", "--timeout-ms",
           "120000"},
          std::chrono::seconds(180));
      const nlohmann::json report = nlohmann::json::parse(run.out, nullptr, false);
      ASSERT_FALSE(report.is_discarded()) << run.out << run.err;
      ASSERT_TRUE(report.value("ok", false)) << report.dump();
      EXPECT_EQ(report["console_errors"], nlohmann::json::array()) << report.dump();
      const std::string url = report.value("value", "");
      const std::string prefix = "data:image/png;base64,";
      ASSERT_EQ(url.rfind(prefix, 0), 0u) << url.substr(0, 80);
      const fs::path webgl_file = kArtifacts / ("webgl_" + name + ".png");
      std::ofstream(webgl_file, std::ios::binary) << testing::Base64Decode(url.substr(prefix.size()));
      int w = 0, h = 0;
      const std::vector<uint8_t> webgl = ReadRgba<uint8_t>(webgl_file, &w, &h);
      ASSERT_EQ(w, kPixels);
      ASSERT_EQ(h, kPixels);

      int both = 0, either = 0, large = 0;
      double squared_error = 0, bias = 0;
      std::vector<uint8_t> diff(webgl.size(), 0);  // |webgl - reference| x 4, opaque where either covers
      for (size_t p = 0; p < webgl.size(); p += 4) {
        const bool a = webgl[p + 3] >= 128, b = reference.albedo_alpha[p + 3] >= 128;
        either += a || b;
        diff[p + 3] = (a || b) ? 255 : 0;
        if (a != b) diff[p] = 255;  // silhouette mismatch in red
        if (!(a && b)) continue;
        ++both;
        int worst = 0;
        for (int k = 0; k < 3; ++k) {
          const int d = webgl[p + k] - reference.albedo_alpha[p + k];
          squared_error += (d / 255.0) * (d / 255.0);
          bias += d;
          worst = std::max(worst, std::abs(d));
          diff[p + k] = static_cast<uint8_t>(std::min(255, std::abs(d) * 4));
        }
        large += worst > 16;
      }
      WriteRgba8(kArtifacts / ("diff_" + name + ".png"), diff, kPixels, kPixels);
      ASSERT_GT(either, kPixels * kPixels / 20) << "the impostor covers almost nothing";
      const double iou = static_cast<double>(both) / either;
      const double mse = squared_error / (3.0 * std::max(both, 1));
      const double psnr = mse > 0 ? 10 * std::log10(1.0 / mse) : 99;
      EXPECT_GE(iou, 0.98) << "silhouette IoU; images in " << kArtifacts;
      EXPECT_GE(psnr, kMinPsnrDb) << "albedo PSNR over the shared silhouette; images in " << kArtifacts;
      EXPECT_LE(static_cast<double>(large) / std::max(both, 1), kMaxLargeFraction)
          << "shared pixels off by more than 16 levels; images in " << kArtifacts;
      std::printf("%s: IoU %.4f, albedo PSNR %.2f dB, mean difference %.2f levels, %.1f%% of pixels off by > 16\n",
                  name.c_str(), iou, psnr, bias / (3.0 * std::max(both, 1)), 100.0 * large / std::max(both, 1));
    }
  }
}

}  // namespace
}  // namespace impostor
