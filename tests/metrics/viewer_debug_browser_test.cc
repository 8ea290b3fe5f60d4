// The result page's debug views in headless Chromium (issue 16):
//  - the atlas panel marks, for a fixed orbit camera, exactly the frames the
//    C++ runtime (BlendFrames, what the reference renderer blends) picks for
//    that view direction, with the same weights, for every layout and both
//    blend modes;
//  - the A/B split shows the mesh-only render left of the line and the
//    impostor-only render right of it, and dragging the line moves it.
// No console errors on any page. Screenshots in
// build/test_artifacts/dashboard/ (viewer_LAYOUT.png, ab_split*.png).
#include <algorithm>
#include <cmath>
#include <filesystem>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "common/runtime/frame_blend.h"
#include "tests/support/server_process.h"
#include "tests/metrics/browser_capture.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::ServerProcess;

const fs::path kArtifacts = fs::path(IMPOSTOR_TEST_ARTIFACTS_DIR) / "dashboard";
constexpr double kAzimuthDeg = 35, kElevationDeg = 20, kDistanceRadii = 4;
constexpr float kWeightTolerance = 1e-3f;  // float32 on SwiftShader vs the C++

class ViewerDebugTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    fs::create_directories(kArtifacts);
    server_ = new ServerProcess(/*local_workers=*/1, {"--http-listen=127.0.0.1:0"});
    const std::string line = server_->process().ReadLineContaining("http listening on");
    ASSERT_FALSE(line.empty());
    port_ = std::stoi(line.substr(line.rfind(':') + 1));
    const v1::MeshInput mesh = testing::UploadGlb(
        server_->assets(), testing::AssetsDir() / "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb");
    const std::vector<std::string> jobs = testing::SubmitEveryLayout(*server_, mesh);
    for (size_t i = 0; i < jobs.size(); ++i) {
      const v1::Job done = testing::WatchToEnd(server_->bake(), jobs[i]);
      ASSERT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << testing::kEveryLayout[i].name << ": " << done.error().message();
      manifests_.push_back(done.result());
    }
  }
  static void TearDownTestSuite() {
    delete server_;
    server_ = nullptr;
    manifests_.clear();
  }
  void SetUp() override {
    ASSERT_TRUE(fs::exists("/usr/bin/chromium")) << "chromium is not installed (deploy/install-deps.sh)";
    ASSERT_EQ(manifests_.size(), std::size(testing::kEveryLayout)) << "the bakes did not all succeed";
  }
  static std::string CameraQuery() {
    return "camera=" + std::to_string(kAzimuthDeg) + "," + std::to_string(kElevationDeg) + "," +
           std::to_string(kDistanceRadii);
  }

  static ServerProcess* server_;
  static int port_;
  static std::vector<v1::Manifest> manifests_;
};
ServerProcess* ViewerDebugTest::server_ = nullptr;
int ViewerDebugTest::port_ = 0;
std::vector<v1::Manifest> ViewerDebugTest::manifests_;

struct Entry {
  int index;
  float weight;
  int col, row;
};
std::vector<Entry> SortedByIndex(std::vector<Entry> entries) {
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) { return a.index < b.index; });
  return entries;
}

TEST_F(ViewerDebugTest, AtlasPanelMarksTheFramesTheRuntimeBlendsForEveryLayout) {
  const double az = kAzimuthDeg * M_PI / 180, el = kElevationDeg * M_PI / 180;
  const glm::vec3 direction(std::sin(az) * std::cos(el), std::sin(el), std::cos(az) * std::cos(el));
  for (size_t i = 0; i < std::size(testing::kEveryLayout); ++i) {
    const testing::LayoutCase& c = testing::kEveryLayout[i];
    SCOPED_TRACE(c.name);
    const v1::Manifest& m = manifests_[i];
    const nlohmann::json report = testing::RunPage(
        port_, "/results/" + m.cache_key() + "?" + CameraQuery(), "document.body.dataset.viewerReady === '1'",
        "({triangle3: window.impostorViewer.setBlend(0), bilinear4: window.impostorViewer.setBlend(1),"
        " legend: document.getElementById('active-frames').textContent})",
        kArtifacts / ("viewer_" + std::string(c.name) + ".png"));
    ASSERT_TRUE(report.value("ok", false)) << report.dump();
    EXPECT_EQ(report["console_errors"], nlohmann::json::array()) << report.dump();
    EXPECT_NE(report["value"].value("legend", "").find("weight"), std::string::npos) << report.dump();

    const ViewLayout layout{.kind = c.kind,
                            .frames = static_cast<int>(m.frames()),
                            .ring_views = testing::RingViews(c.kind, m)};
    for (const auto& [mode_name, mode] :
         {std::pair{"triangle3", BlendMode::kTriangle3}, std::pair{"bilinear4", BlendMode::kBilinear4}}) {
      SCOPED_TRACE(mode_name);
      const FrameBlend want_blend = BlendFrames(layout, direction, mode);
      std::vector<Entry> want;
      for (int k = 0; k < want_blend.count; ++k) {
        const FrameWeight& e = want_blend.entries[k];
        want.push_back({e.index, e.weight, e.frame.col, e.frame.row});
      }
      std::vector<Entry> got;
      const nlohmann::json& marked = report["value"][mode_name];
      ASSERT_TRUE(marked.is_array()) << report.dump();
      for (const auto& e : marked) {
        got.push_back({e["index"].get<int>(), e["weight"].get<float>(), e["tile"][0].get<int>(), e["tile"][1].get<int>()});
      }
      want = SortedByIndex(want);
      got = SortedByIndex(got);
      ASSERT_EQ(got.size(), want.size()) << marked.dump();
      ASSERT_GE(got.size(), 1u);
      for (size_t k = 0; k < want.size(); ++k) {
        EXPECT_EQ(got[k].index, want[k].index) << marked.dump();
        EXPECT_NEAR(got[k].weight, want[k].weight, kWeightTolerance) << "frame " << want[k].index;
        EXPECT_EQ(got[k].col, want[k].col) << "frame " << want[k].index;
        EXPECT_EQ(got[k].row, want[k].row) << "frame " << want[k].index;
      }
    }
  }
}

// A synthetic drag of the split line from the middle to 30% of the width,
// then the three canvases' pixels.
constexpr char kDragThenCapture[] = R"JS((() => {
  const c = document.getElementById('ab');
  const r = c.getBoundingClientRect();
  const y = r.top + r.height / 2;
  const send = (type, f) => c.dispatchEvent(new PointerEvent(type,
      { clientX: r.left + f * r.width, clientY: y, bubbles: true, cancelable: true, pointerId: 1, button: 0 }));
  send('pointerdown', 0.5); send('pointermove', 0.4); send('pointermove', 0.3); send('pointerup', 0.3);
  return window.impostorViewer.pngs();
})())JS";

TEST_F(ViewerDebugTest, AbSplitShowsTheMeshLeftAndTheImpostorRightOfTheDraggedLine) {
  const v1::Manifest& m = manifests_[0];  // octahedral
  const nlohmann::json report =
      testing::RunPage(port_, "/results/" + m.cache_key() + "?" + CameraQuery() + "&compare=ab&split=0.5",
                       "document.body.dataset.viewerReady === '1'", kDragThenCapture, kArtifacts / "ab_split.png");
  ASSERT_TRUE(report.value("ok", false)) << report.dump();
  EXPECT_EQ(report["console_errors"], nlohmann::json::array()) << report.dump();
  const nlohmann::json& v = report["value"];
  int w = 0, h = 0, mw = 0, mh = 0, iw = 0, ih = 0;
  const auto ab = testing::SavePngDataUrl(v.value("ab", ""), kArtifacts / "ab_split_canvas.png", &w, &h);
  const auto mesh = testing::SavePngDataUrl(v.value("mesh", ""), kArtifacts / "ab_split_mesh.png", &mw, &mh);
  const auto impostor =
      testing::SavePngDataUrl(v.value("impostor", ""), kArtifacts / "ab_split_impostor.png", &iw, &ih);
  ASSERT_FALSE(ab.empty());
  ASSERT_EQ(mw, w);
  ASSERT_EQ(iw, w);
  ASSERT_EQ(mh, h);
  ASSERT_EQ(ih, h);
  const int split = v.value("split_px", -1);
  EXPECT_EQ(split, static_cast<int>(std::lround(0.3 * w))) << "the drag did not move the line to 30%";

  // The impostor canvas is transparent where the impostor is not: the A/B
  // canvas shows it over black.
  auto impostor_over_black = [&](size_t p, int k) -> int {
    return impostor[p + 3] == 0 ? 0 : impostor[p + k] * impostor[p + 3] / 255;
  };
  int left_off = 0, right_off = 0, left_differs = 0, right_differs = 0, worst = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (std::abs(x - split) <= 1) continue;  // the line
      const size_t p = (static_cast<size_t>(y) * w + x) * 4;
      int d_mesh = 0, d_impostor = 0;
      for (int k = 0; k < 3; ++k) {
        d_mesh = std::max(d_mesh, std::abs(ab[p + k] - mesh[p + k]));
        d_impostor = std::max(d_impostor, std::abs(ab[p + k] - impostor_over_black(p, k)));
      }
      if (x < split) {
        left_off += d_mesh > 2;
        left_differs += d_impostor > 2;
        worst = std::max(worst, d_mesh);
      } else {
        right_off += d_impostor > 2;
        right_differs += d_mesh > 2;
        worst = std::max(worst, d_impostor);
      }
    }
  }
  EXPECT_EQ(left_off, 0) << "pixels left of the split that differ from the mesh render; images in " << kArtifacts;
  EXPECT_EQ(right_off, 0) << "pixels right of the split that differ from the impostor render; images in "
                          << kArtifacts;
  // The two renders differ (lit mesh vs unlit albedo), or the test could not
  // tell the sides apart.
  EXPECT_GT(left_differs, 100);
  EXPECT_GT(right_differs, 100);
  std::printf("A/B split at x=%d of %d: worst difference %d levels; %d/%d pixels tell the sides apart\n", split, w,
              worst, left_differs, right_differs);
}

TEST_F(ViewerDebugTest, SplitOutOfRangeIsClampedNotBroken) {
  const v1::Manifest& m = manifests_[0];
  const nlohmann::json report = testing::RunPage(
      port_, "/results/" + m.cache_key() + "?" + CameraQuery() + "&compare=ab&split=7",
      "document.body.dataset.viewerReady === '1'", "[window.impostorViewer.split(), window.impostorViewer.setSplit(-3)]");
  ASSERT_TRUE(report.value("ok", false)) << report.dump();
  EXPECT_EQ(report["console_errors"], nlohmann::json::array()) << report.dump();
  EXPECT_EQ(report["value"], nlohmann::json::array({1, 0})) << report.dump();
}

}  // namespace
}  // namespace impostor
