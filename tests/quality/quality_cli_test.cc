// `impostor bake --min-iou/--min-psnr/--frames auto` and `impostor quality`
// as a person or CI runs them: the real tool against a real impostor-server
// with a local worker on loopback (lavapipe suffices). The gate's thresholds
// are set around the figures the first bake measured.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct CliRun {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

CliRun Shell(const std::string& command) {
  ChildProcess p({"/bin/sh", "-c", command + " 2>&1"});
  CliRun r;
  r.exit_code = p.Wait(&r.output);
  return r;
}

std::string Q(const std::string& s) { return "'" + s + "'"; }

json ReadJson(const fs::path& path) {
  std::ifstream in(path);
  return json::parse(in, nullptr, /*allow_exceptions=*/false);
}

TEST(QualityCli, GateFailsAndPassesAroundTheMeasuredBakeAndQualityReports) {
  ServerProcess server(1);
  const fs::path dir = NewTempDir("quality_cli");
  const std::string model = (AssetsDir() / "props_pbr/Duck/glTF-Binary/Duck.glb").string();
  const std::string impostor = (BinaryDir() / "impostor").string();
  const std::string common = " --frames 4 --resolution 128 --quality-views 4 --server " + server.address();

  // An ungated bake: exit 0, the summary on stderr, the block in the manifest.
  const CliRun plain = Shell(impostor + " bake " + Q(model) + " --out " + Q((dir / "plain").string()) + common);
  ASSERT_EQ(plain.exit_code, 0) << plain.output;
  EXPECT_NE(plain.output.find("quality: IoU "), std::string::npos) << plain.output;
  const json manifest = ReadJson(dir / "plain/manifest.json");
  ASSERT_TRUE(manifest.contains("quality")) << manifest.dump();
  const double iou = manifest["quality"]["silhouette_iou_mean"].get<double>();
  const double psnr = manifest["quality"]["albedo_psnr_shared_db_mean"].get<double>();
  EXPECT_EQ(manifest["quality"]["views"], 4);
  EXPECT_TRUE(fs::exists(dir / "plain/quality_worst_view.png"));
  std::printf("Duck 4x4 128 px: IoU mean %.4f, PSNR mean %.2f dB\n", iou, psnr);

  // Thresholds just above what was measured: FAILED_PRECONDITION with the
  // measured values, exit 1, and the result downloaded anyway.
  char above[128];
  std::snprintf(above, sizeof above, " --min-iou %.4f --min-psnr %.2f", std::min(1.0, iou + 0.01), psnr - 1.0);
  const CliRun gated = Shell(impostor + " bake " + Q(model) + " --out " + Q((dir / "gated").string()) + common + above);
  EXPECT_EQ(gated.exit_code, 1) << gated.output;
  EXPECT_NE(gated.output.find("FAILED_PRECONDITION: quality gate: silhouette IoU "), std::string::npos)
      << gated.output;
  EXPECT_NE(gated.output.find("min_iou"), std::string::npos) << gated.output;
  EXPECT_TRUE(fs::exists(dir / "gated/manifest.json")) << "kept for inspection: " << gated.output;
  EXPECT_TRUE(fs::exists(dir / "gated/albedo_alpha.png"));

  // Just below: it passes.
  char below[128];
  std::snprintf(below, sizeof below, " --min-iou %.4f --min-psnr %.2f", iou - 0.01, psnr - 1.0);
  const CliRun passed = Shell(impostor + " bake " + Q(model) + " --out " + Q((dir / "passed").string()) + common + below);
  EXPECT_EQ(passed.exit_code, 0) << passed.output;

  // impostor quality KEY: the report and the worst view's image.
  const std::string key = manifest["cache_key"].get<std::string>();
  const CliRun report = Shell(impostor + " quality " + key + " --out " + Q((dir / "report").string()) +
                           " --server " + server.address());
  EXPECT_EQ(report.exit_code, 0) << report.output;
  for (const char* line : {"silhouette IoU", "albedo PSNR", "albedo SSIM", "normal error", "depth error", "pop",
                           "quality_worst_view.png"}) {
    EXPECT_NE(report.output.find(line), std::string::npos) << line << " missing from:\n" << report.output;
  }
  EXPECT_TRUE(fs::exists(dir / "report/quality_worst_view.png"));

  // Usage errors are caught by the tool.
  const CliRun bad = Shell(impostor + " bake " + Q(model) + " --out " + Q((dir / "bad").string()) + " --min-iou high");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("--min-iou: expected a number"), std::string::npos) << bad.output;
  // --frames auto without a target: the server refuses, naming the field.
  const CliRun no_target = Shell(impostor + " bake " + Q(model) + " --out " + Q((dir / "auto").string()) +
                              " --frames auto --resolution 128 --server " + server.address());
  EXPECT_EQ(no_target.exit_code, 1) << no_target.output;
  EXPECT_NE(no_target.output.find("parameters.auto_target"), std::string::npos) << no_target.output;
  // Nothing under that key or job id: the server's answer, exit 1 (CI
  // retries exit 3, the farm's trouble, not this); a key that cannot be
  // one is a usage error, refused before connecting.
  const std::string never = std::string(64, '0');
  for (const std::string& command : {" quality " + never, " fetch " + never + " --out " + Q((dir / "none").string()),
                                     std::string(" status job-that-never-was")}) {
    const CliRun missing = Shell(impostor + command + " --server " + server.address());
    EXPECT_EQ(missing.exit_code, 1) << command << ": " << missing.output;
    EXPECT_NE(missing.output.find("NOT_FOUND"), std::string::npos) << command << ": " << missing.output;
  }
  const CliRun not_a_key = Shell(impostor + " quality nothex --server 127.0.0.1:1");
  EXPECT_EQ(not_a_key.exit_code, 2) << not_a_key.output;
  EXPECT_NE(not_a_key.output.find("cache key \"nothex\": expected 64 lowercase hex characters"), std::string::npos)
      << not_a_key.output;
}

}  // namespace
}  // namespace impostor::testing
