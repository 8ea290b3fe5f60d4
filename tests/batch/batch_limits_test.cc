// `impostor bake-batch` against a server's limits: per-token quotas that
// pass with time (an asset the quota refuses is held back and submitted
// again, not failed) and a server that is gone for good (the whole batch
// ends within --max-outage-seconds, however many assets are left). Real
// impostor-server and `impostor` processes on loopback; small bakes keep
// lavapipe fast.
#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "absl/strings/str_split.h"
#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

fs::path Box() { return AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb"; }

std::string Impostor() { return (BinaryDir() / "impostor").string(); }

// `count` distinct bakes of the Box (frames 3, 4, ...), named f3, f4, ...
fs::path DistinctBakesSpec(const fs::path& dir, int count) {
  json spec = {{"defaults", {{"resolution", 128}, {"quality_views", 0}}}, {"assets", json::array()}};
  for (int frames = 3; frames < 3 + count; ++frames) {
    spec["assets"].push_back({{"path", Box().string()}, {"name", "f" + std::to_string(frames)}, {"frames", frames}});
  }
  const fs::path file = dir / "distinct.json";
  std::ofstream(file) << spec.dump();
  return file;
}

fs::path TokenFile(const ServerProcess& server, const fs::path& dir) {
  const fs::path file = dir / "ci.token";
  std::ofstream(file) << CreateToken(server.data_dir(), "submitter", "ci") << "\n";
  return file;
}

struct JsonLines {
  std::vector<json> assets;
  json summary;
};

JsonLines ParseLines(const std::string& out) {
  JsonLines lines;
  for (absl::string_view line : absl::StrSplit(out, '\n', absl::SkipEmpty())) {
    json j = json::parse(line, nullptr, /*allow_exceptions=*/false);
    EXPECT_TRUE(j.is_object()) << "not a JSON object: " << line;
    if (!j.is_object()) continue;
    if (j.value("type", "") == "asset") lines.assets.push_back(j);
    if (j.value("type", "") == "summary") lines.summary = j;
  }
  return lines;
}

// 8 bakes through a token allowed 2 pending jobs: the 6 it refuses at first
// are held and submitted again as the batch's own jobs finish.
TEST(BatchLimits, PendingJobsQuotaHoldsAssetsBackUntilTheBatchsOwnJobsFinish) {
  ServerProcess server(1, {"--auth=token", "--token-max-pending-jobs=2"});
  const fs::path dir = NewTempDir("batch_pending_quota");
  const ToolRun run =
      RunTool({Impostor(), "bake-batch", DistinctBakesSpec(dir, 8).string(), "--out", (dir / "out").string(),
               "--server", server.address(), "--token-file", TokenFile(server, dir).string(), "--json",
               "--keep-going"});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  const JsonLines lines = ParseLines(run.out);
  ASSERT_EQ(lines.assets.size(), 8u) << run.out;
  for (const json& a : lines.assets) {
    EXPECT_EQ(a["status"], "succeeded") << a.dump();
    EXPECT_EQ(a["error_code"], 0) << a.dump();
    EXPECT_TRUE(fs::exists(fs::path(a["out_dir"].get<std::string>()) / "manifest.json")) << a.dump();
  }
  EXPECT_EQ(lines.summary["succeeded"], 8) << run.out;
  EXPECT_EQ(lines.summary["failed"], 0) << run.out;
  // The log says why assets waited, naming the quota.
  EXPECT_NE(run.err.find("pending jobs of token 'ci'"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("holding assets back"), std::string::npos) << run.err;
}

// A rate quota (bakes per hour) does not free up within the batch: the held
// assets give up after --max-outage-seconds without progress, failed with
// the server's refusal (RESOURCE_EXHAUSTED, code 8), and the bakes the quota
// allowed succeed. `impostor bake` waits as long, then fails with it.
TEST(BatchLimits, RateQuotaGivesUpAfterTheOutageBudgetWithTheRefusal) {
  ServerProcess server(1, {"--auth=token", "--token-max-bakes-per-hour=2"});
  const fs::path dir = NewTempDir("batch_rate_quota");
  const fs::path token = TokenFile(server, dir);
  const auto start = std::chrono::steady_clock::now();
  const ToolRun run = RunTool({Impostor(), "bake-batch", DistinctBakesSpec(dir, 4).string(), "--out",
                               (dir / "out").string(), "--server", server.address(), "--token-file", token.string(),
                               "--json", "--keep-going", "--max-outage-seconds=2"});
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(run.exit_code, 1) << run.err;
  const JsonLines lines = ParseLines(run.out);
  ASSERT_EQ(lines.assets.size(), 4u) << run.out;
  int succeeded = 0;
  for (const json& a : lines.assets) {
    if (a["status"] == "succeeded") {
      ++succeeded;
      continue;
    }
    EXPECT_EQ(a["status"], "failed") << a.dump();
    EXPECT_EQ(a["error_code"], 8) << a.dump();
    EXPECT_NE(a["error"].get<std::string>().find("bakes of token 'ci'"), std::string::npos) << a.dump();
    EXPECT_NE(a["error"].get<std::string>().find("held back"), std::string::npos) << a.dump();
    EXPECT_EQ(a["error_reason"], "TOKEN_BAKES_PER_HOUR") << a.dump();
  }
  EXPECT_EQ(succeeded, 2) << run.out;
  EXPECT_GE(seconds, 2.0) << "the held assets were tried again for --max-outage-seconds";
  EXPECT_NE(run.err.find("holding assets back"), std::string::npos) << run.err;

  const ToolRun bake = RunTool({Impostor(), "bake", Box().string(), "--frames", "9", "--resolution", "128", "--out",
                                (dir / "single").string(), "--server", server.address(), "--token-file",
                                token.string(), "--max-outage-seconds=1"});
  EXPECT_EQ(bake.exit_code, 3) << bake.err;
  EXPECT_NE(bake.err.find("waiting for the quota"), std::string::npos) << bake.err;
  EXPECT_NE(bake.err.find("RESOURCE_EXHAUSTED"), std::string::npos) << bake.err;
}

// How many lines of `text` contain `needle`.
int LinesContaining(const std::string& text, const std::string& needle) {
  int n = 0;
  for (absl::string_view line : absl::StrSplit(text, '\n')) n += line.find(needle) != absl::string_view::npos;
  return n;
}

// The token's one bake of the hour is spent before the batch starts, and
// the batch has ONE new asset: the held asset is the last one every time it
// is refused again, which must not start the hold over (it used to: the
// batch never ended and printed the holding line once a second). It gives
// up after --max-outage-seconds without progress, failed with the quota's
// refusal, and the holding line comes once. `impostor bake` in the same
// spot waits as long and exits 3 (retry later), where the batch exits 1 (an
// asset failed; its error_code 8 says why).
TEST(BatchLimits, OneHeldAssetGivesUpAfterTheOutageBudgetAndSaysSoOnce) {
  ServerProcess server(0, {"--auth=token", "--token-max-bakes-per-hour=1"});  // no worker: nothing ends
  const fs::path dir = NewTempDir("batch_one_held");
  const std::string secret = CreateToken(server.data_dir(), "submitter", "ci");
  ASSERT_FALSE(secret.empty());
  const fs::path token = dir / "ci.token";
  std::ofstream(token) << secret << "\n";
  // The hour's one bake: a submit that is not a cache hit counts.
  server.UseToken(secret);
  v1::SubmitBakeRequest request;
  *request.mutable_mesh() = UploadGlb(server.assets(), Box());
  request.mutable_parameters()->set_frames(9);
  request.mutable_parameters()->set_resolution(128);
  v1::SubmitBakeResponse first;
  ASSERT_TRUE(server.bake().SubmitBake(ContextWithin().get(), request, &first).ok());
  ASSERT_FALSE(first.cached());

  constexpr double kBudget = 3;
  const auto start = std::chrono::steady_clock::now();
  const ToolRun run = RunTool({Impostor(), "bake-batch", DistinctBakesSpec(dir, 1).string(), "--out",
                               (dir / "out").string(), "--server", server.address(), "--token-file", token.string(),
                               "--json", "--max-outage-seconds=3"},
                              std::chrono::seconds(60));
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(run.exit_code, 1) << run.err;
  EXPECT_GE(seconds, kBudget) << "the held asset was tried again for --max-outage-seconds";
  EXPECT_LT(seconds, kBudget + 10) << "gave up " << seconds << " s after starting";
  const JsonLines lines = ParseLines(run.out);
  ASSERT_EQ(lines.assets.size(), 1u) << run.out;
  const json& a = lines.assets[0];
  EXPECT_EQ(a["status"], "failed") << a.dump();
  EXPECT_EQ(a["error_code"], 8) << a.dump();
  EXPECT_EQ(a["error_reason"], "TOKEN_BAKES_PER_HOUR") << a.dump();
  const std::string error = a["error"].is_string() ? a["error"].get<std::string>() : "";
  EXPECT_EQ(error.rfind("RESOURCE_EXHAUSTED: ", 0), 0u) << error;
  EXPECT_NE(error.find("bakes of token 'ci'"), std::string::npos) << error;
  EXPECT_NE(error.find("held back"), std::string::npos) << error;
  EXPECT_EQ(lines.summary["exit_code"], 1) << run.out;
  EXPECT_EQ(lines.summary["failed"], 1) << run.out;
  // One line for the hold, naming the quota; one for the failure.
  EXPECT_EQ(LinesContaining(run.err, "holding assets back"), 1) << run.err;
  EXPECT_EQ(LinesContaining(run.err, "bakes of token 'ci'"), 2) << run.err;
  // The backoff doubles from 1 s: refused at 0 s and 1 s; the next try
  // would be at 3 s, where the budget ends (a backoff that started over
  // tried every second).
  ASSERT_TRUE(server.process().WaitForLog("outcome=RESOURCE_EXHAUSTED", 2));
  EXPECT_EQ(server.process().CountInLog("outcome=RESOURCE_EXHAUSTED"), 2);

  const ToolRun bake = RunTool({Impostor(), "bake", Box().string(), "--frames", "5", "--resolution", "128", "--out",
                                (dir / "single").string(), "--server", server.address(), "--token-file",
                                token.string(), "--json", "--max-outage-seconds=1"},
                               std::chrono::seconds(60));
  EXPECT_EQ(bake.exit_code, 3) << bake.err;
  const json j = json::parse(bake.out, nullptr, /*allow_exceptions=*/false);
  ASSERT_TRUE(j.is_object()) << bake.out;
  EXPECT_EQ(j["exit_code"], 3) << bake.out;
  const std::string bake_error = j["error"].is_string() ? j["error"].get<std::string>() : "";
  EXPECT_EQ(bake_error.rfind("RESOURCE_EXHAUSTED: ", 0), 0u) << bake.out;
  EXPECT_NE(bake_error.find("bakes of token 'ci'"), std::string::npos) << bake.out;
  EXPECT_EQ(LinesContaining(bake.err, "waiting for the quota"), 1) << bake.err;
}

// The server is killed and stays away while 100 assets wait for a watcher:
// the batch reports every one of them and exits within --max-outage-seconds
// plus a few seconds, not a fraction of a second per remaining asset.
TEST(BatchLimits, ALostServerEndsTheWholeBatchWithinTheOutageBudget) {
  ServerProcess server(0);  // no worker: every job stays queued
  const fs::path dir = NewTempDir("batch_lost_server");
  constexpr int kAssets = 100;
  json spec = {{"defaults", {{"frames", 3}, {"resolution", 64}}}, {"assets", json::array()}};
  for (int i = 0; i < kAssets; ++i) spec["assets"].push_back({{"path", Box().string()}, {"name", "a" + std::to_string(i)}});
  std::ofstream(dir / "spec.json") << spec.dump();
  constexpr double kBudget = 3;
  ChildProcess cli({Impostor(), "bake-batch", (dir / "spec.json").string(), "--out", (dir / "out").string(), "--server",
                    server.address(), "--json", "--keep-going", "--max-outage-seconds=3"});
  ASSERT_TRUE(server.process().WaitForLog("event=submit ", kAssets)) << cli.Stderr();
  server.Kill();
  const auto killed = std::chrono::steady_clock::now();
  std::string out;
  const int exit_code = cli.Wait(&out, std::chrono::seconds(120));
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - killed).count();
  EXPECT_EQ(exit_code, 3) << cli.Stderr();
  EXPECT_LT(seconds, kBudget + 4) << "gave up " << seconds << " s after the kill";
  const JsonLines lines = ParseLines(out);
  ASSERT_EQ(lines.assets.size(), static_cast<size_t>(kAssets)) << out;
  for (const json& a : lines.assets) {
    EXPECT_EQ(a["status"], "failed") << a.dump();
    EXPECT_EQ(a["error_code"], 14) << a.dump();  // UNAVAILABLE
    // "UNAVAILABLE: not followed: ...": the code first, as every error.
    EXPECT_EQ(a["error"].get<std::string>().rfind("UNAVAILABLE: ", 0), 0u) << a.dump();
  }
  EXPECT_EQ(lines.summary["exit_code"], 3) << out;
  EXPECT_EQ(lines.summary["failed"], kAssets) << out;
}

}  // namespace
}  // namespace impostor::testing
