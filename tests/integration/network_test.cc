// The farm over a network that misbehaves, with real processes:
//  - a worker whose input download, or output upload, is cut by a server
//    restart resumes it within --max-outage-seconds and finishes the job on
//    its first attempt;
//  - connections cut (not a kill: the server keeps running) between the CLI
//    and the server and between the worker and the server, mid-watch and
//    mid-transfer: the bake completes, byte-identical to an uncut run;
//  - `impostor bake-batch` with more than 8 distinct assets follows them over
//    at most 8 WatchJob streams at once (counted by the server), and its
//    summary counts a bake shared with another requester as `baked`.
//
// Points in time come from events: a worker pauses at its render stage while
// a test-controlled file exists, a TCP proxy freezes a direction after a
// byte count, processes' logs are awaited with inotify. No sleeps.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/integration/farm_processes.h"
#include "tests/support/result_digest.h"
#include "tests/support/server_process.h"
#include "tests/support/tcp_proxy.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::AssetsDir;
using testing::BinaryDir;
using testing::ChildProcess;
using testing::ServerProcess;
using testing::TcpProxy;

constexpr char kPauseEnv[] = "IMPOSTOR_WORKER_TEST_PAUSE_FILE";
constexpr char kBox[] = "props_pbr/Box/glTF-Binary/Box.glb";
constexpr char kBoxTextured[] = "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb";
constexpr auto kFreezeDeadline = std::chrono::seconds(120);

testing::ProcessOptions Named(const std::string& name) {
  testing::ProcessOptions options;
  options.name = name;
  return options;
}

// `impostor bake MODEL` at a small size, into `out`.
std::vector<std::string> BakeCommand(const fs::path& model, const fs::path& out, const std::string& server,
                                     std::vector<std::string> extra = {}) {
  std::vector<std::string> argv = {(BinaryDir() / "impostor").string(),
                                   "bake",
                                   model.string(),
                                   "--out",
                                   out.string(),
                                   "--server",
                                   server,
                                   "--frames=3",
                                   "--resolution=64",
                                   "--quality-views=0"};
  argv.insert(argv.end(), extra.begin(), extra.end());
  return argv;
}

// The job id from the CLI's "submitted MODEL: job ID, ..." line.
std::string SubmittedJobId(const std::string& cli_stderr) {
  std::smatch m;
  static const std::regex kLine(R"(submitted [^\n]*: job ([^,\s]+),)");
  return std::regex_search(cli_stderr, m, kLine) ? m[1].str() : "";
}

// The server dies under a worker's transfer (through `proxy`) and comes back
// on its address: the job must then finish on the attempt it was on, with
// one of `rpcs` retried through the outage and no attempt failed.
void RestartUnderTheWorker(ServerProcess& server, TcpProxy& proxy, ChildProcess& worker, const std::string& job_id,
                           const std::vector<std::string>& rpcs) {
  server.Kill();
  proxy.CutAll();
  server.Restart();
  const v1::Job done = testing::WatchToEnd(server.bake(), job_id);
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.DebugString();
  EXPECT_EQ(done.attempts(), 1u) << "the outage cost an attempt";
  EXPECT_EQ(worker.Wait(), 0);
  int retries = 0;
  for (const std::string& rpc : rpcs) retries += worker.CountInLog("event=rpc_retry rpc=" + rpc);
  EXPECT_GE(retries, 1) << worker.Stderr();
  EXPECT_EQ(worker.CountInLog("event=job_failed"), 0) << worker.Stderr();
  EXPECT_EQ(worker.CountInLog("event=job_start"), 1) << worker.Stderr();
}

TEST(WorkerOutage, InputDownloadCutByAServerRestartResumesOnTheFirstAttempt) {
  ServerProcess server(0);
  // The model, and a 3 MiB input file the worker must download too (the
  // loader never reads it): the proxy freezes the download a third of the
  // way through it.
  const v1::SubmitBakeResponse submitted =
      testing::SubmitWithPaddedInput(server, AssetsDir() / kBoxTextured, 3 << 20, 19);

  TcpProxy proxy(server.address());
  proxy.FreezeAfter(1 << 20, TcpProxy::Direction::kToClient);
  auto worker = testing::StartWorker(proxy.address(), "outage-worker",
                                     {"--max-jobs=1", "--max-outage-seconds=120", "--log-level=info"});
  ASSERT_TRUE(proxy.WaitFrozen(kFreezeDeadline)) << "the worker never got 1 MiB into its inputs";
  const v1::Job mid = testing::GetJob(server.bake(), submitted.job_id());
  ASSERT_EQ(mid.state(), v1::JOB_STATE_RUNNING) << mid.DebugString();
  EXPECT_EQ(mid.attempts(), 1u);

  RestartUnderTheWorker(server, proxy, *worker, submitted.job_id(), {"ReadBlob"});
}

TEST(WorkerOutage, OutputUploadCutByAServerRestartCompletesOnTheFirstAttempt) {
  ServerProcess server(0);
  const fs::path pause = testing::NewTempDir("upload_outage") / "pause";
  testing::Touch(pause);
  const v1::MeshInput mesh = testing::UploadGlb(server.assets(), AssetsDir() / kBoxTextured);
  const v1::SubmitBakeResponse submitted = testing::SubmitSmall(server.bake(), mesh);
  TcpProxy proxy(server.address());
  auto worker = testing::StartWorker(proxy.address(), "upload-worker",
                                     {"--max-jobs=1", "--max-outage-seconds=120", "--log-level=info"},
                                     {{kPauseEnv, pause.string()}});
  testing::WatchUntil(server.bake(), submitted.job_id(),
                      [](const v1::Job& j) { return j.state() == v1::JOB_STATE_RUNNING && j.stage() == "render"; });

  // From here nothing the worker sends reaches the server: its outputs are
  // on their way when the server dies.
  proxy.FreezeAfter(0, TcpProxy::Direction::kToServer);
  fs::remove(pause);
  ASSERT_TRUE(worker->WaitForLog("event=job_upload ", 1, kFreezeDeadline)) << worker->Stderr();
  RestartUnderTheWorker(server, proxy, *worker, submitted.job_id(), {"UploadBlob", "CompleteJob"});
}

TEST(CutConnection, BakeCompletesByteIdenticalWhenClientAndWorkerConnectionsAreCut) {
  const fs::path work = testing::NewTempDir("network_cut");
  const fs::path model = AssetsDir() / kBoxTextured;

  // The uninterrupted run, on a server of its own.
  std::map<std::string, std::string> reference;
  {
    ServerProcess ref(1);
    const testing::ToolRun run = testing::RunTool(BakeCommand(model, work / "reference", ref.address()));
    ASSERT_EQ(run.exit_code, 0) << run.err;
    reference = testing::HashResultDir(work / "reference");
    ASSERT_TRUE(reference.contains("manifest.json") && reference.size() >= 3);
  }

  ServerProcess server(0);
  TcpProxy client_link(server.address());
  TcpProxy worker_link(server.address());
  const fs::path pause = work / "pause";
  testing::Touch(pause);
  auto worker =
      testing::StartWorker(worker_link.address(), "cut-worker", {"--max-jobs=1"}, {{kPauseEnv, pause.string()}});
  ChildProcess cli(BakeCommand(model, work / "out", client_link.address(), {"--max-outage-seconds=120"}),
                   Named("impostor-bake"));

  // Cut 1: the CLI is watching (it printed the render stage) and the worker
  // is held at render, each on a live connection.
  ASSERT_TRUE(cli.WaitForLog("] render", 1, kFreezeDeadline)) << cli.Stderr();
  const std::string job_id = SubmittedJobId(cli.Stderr());
  ASSERT_FALSE(job_id.empty()) << cli.Stderr();
  client_link.CutAll();
  worker_link.CutAll();

  // Cut 2: once the worker has sent 2 KiB more (its outputs going up) and
  // the CLI has received 2 KiB more (watch updates, then its download).
  worker_link.FreezeAfter(2 << 10, TcpProxy::Direction::kToServer);
  client_link.FreezeAfter(2 << 10, TcpProxy::Direction::kToClient);
  fs::remove(pause);
  ASSERT_TRUE(worker_link.WaitFrozen(kFreezeDeadline)) << worker->Stderr();
  worker_link.CutAll();
  ASSERT_TRUE(client_link.WaitFrozen(kFreezeDeadline)) << cli.Stderr();
  client_link.CutAll();

  EXPECT_EQ(cli.Wait(), 0) << cli.Stderr();
  const v1::Job done = testing::WatchToEnd(server.bake(), job_id);
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.DebugString();
  EXPECT_EQ(done.attempts(), 1u) << "a cut connection cost an attempt";
  EXPECT_EQ(testing::HashResultDir(work / "out"), reference) << "the result differs from the uncut bake";
  EXPECT_EQ(worker->Wait(), 0) << worker->Stderr();
}

// The peer_watches counts of the server's `event` lines (watch_open or
// watch_close), by peer: one connection, i.e. one client process.
std::map<std::string, std::vector<int>> WatchCountsByPeer(const std::string& log, const std::string& event) {
  std::map<std::string, std::vector<int>> out;
  static const std::regex kFields(R"re( peer="([^"]*)" peer_watches=(-?\d+) )re");
  std::istringstream lines(log);
  std::smatch m;
  for (std::string line; std::getline(lines, line);) {
    if (line.find("event=" + event + " ") == std::string::npos) continue;
    if (std::regex_search(line, m, kFields)) out[m[1].str()].push_back(std::stoi(m[2].str()));
  }
  return out;
}

TEST(BakeBatchWatches, AtMostEightStreamsForTenAssetsAndASharedBakeCountsAsBaked) {
  const fs::path work = testing::NewTempDir("batch_watches");
  ServerProcess server(0, {"--log-level=debug"});
  const fs::path pause = work / "pause";
  testing::Touch(pause);
  auto worker = testing::StartWorker(server.address(), "batch-worker", {}, {{kPauseEnv, pause.string()}});

  // Another requester's bake of the batch's first asset, held at render:
  // the batch's submission of that asset shares its bake.
  const fs::path box = AssetsDir() / kBox;
  ChildProcess other(BakeCommand(box, work / "other", server.address(), {"--client-id=other-requester"}),
                     Named("impostor-bake"));
  ASSERT_TRUE(other.WaitForLog("] render", 1, kFreezeDeadline)) << other.Stderr();

  // Ten distinct assets: the Box at ten resolutions (one is the shared one).
  constexpr int kAssets = 10;
  nlohmann::json spec = {{"defaults", {{"frames", 3}, {"quality_views", 0}}}, {"assets", nlohmann::json::array()}};
  for (int i = 0; i < kAssets; ++i) {
    spec["assets"].push_back({{"path", box.string()}, {"name", "box-" + std::to_string(64 + 8 * i)},
                              {"resolution", 64 + 8 * i}});
  }
  std::ofstream(work / "batch.json") << spec.dump();
  ChildProcess batch({(BinaryDir() / "impostor").string(), "bake-batch", (work / "batch.json").string(), "--out",
                      (work / "out").string(), "--server", server.address(), "--json", "--quiet",
                      "--client-id=batch-test"},
                     Named("impostor-bake-batch"));

  // Every asset submitted (the other requester's bake and the batch's ten),
  // and the batch at its cap of streams, while no job can finish.
  ASSERT_TRUE(server.process().WaitForLog("event=submit job=", 1 + kAssets, kFreezeDeadline))
      << server.process().Stderr();
  // The other requester holds one stream on its own connection; only the
  // batch can get to 8.
  ASSERT_TRUE(server.process().WaitForLog(" peer_watches=8 ", 1, kFreezeDeadline))
      << "the batch never had 8 streams open\n"
      << server.process().Stderr();
  EXPECT_EQ(server.process().CountInLog("outcome=shares_bake"), 1) << server.process().Stderr();
  fs::remove(pause);

  std::string out;
  EXPECT_EQ(batch.Wait(&out), 0) << out << batch.Stderr();
  EXPECT_EQ(other.Wait(), 0) << other.Stderr();

  // Per connection: the batch's opened every job's stream, at most 8 at
  // once, and closed them all; the other requester's, one.
  const std::string log = server.process().Stderr();
  const auto opened = WatchCountsByPeer(log, "watch_open");
  const auto closed = WatchCountsByPeer(log, "watch_close");
  ASSERT_GE(opened.size(), 2u) << "two client processes watched\n" << log;
  // The batch's connection is the one that opened the most streams.
  const auto batch_peer = std::max_element(opened.begin(), opened.end(), [](const auto& a, const auto& b) {
    return a.second.size() < b.second.size();
  });
  const int batch_max = *std::max_element(batch_peer->second.begin(), batch_peer->second.end());
  const size_t batch_opened = batch_peer->second.size();
  for (const auto& [peer, counts] : opened) {
    const int max = *std::max_element(counts.begin(), counts.end());
    if (peer != batch_peer->first) EXPECT_EQ(max, 1) << peer << ": the other requester's one stream";
    ASSERT_TRUE(closed.contains(peer)) << peer;
    EXPECT_EQ(closed.at(peer).size(), counts.size()) << peer << ": every stream closed";
    EXPECT_GE(std::count(closed.at(peer).begin(), closed.at(peer).end(), 0), 1) << peer;
  }
  EXPECT_EQ(batch_max, 8) << "the batch's streams at once";
  EXPECT_GE(batch_opened, static_cast<size_t>(kAssets)) << "every job followed";

  // The summary: ten baked (one of them shared with the other requester),
  // none cached; the farm ran ten bakes, one per distinct asset.
  nlohmann::json summary;
  int asset_lines = 0;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);) {
    const nlohmann::json j = nlohmann::json::parse(line, nullptr, /*allow_exceptions=*/false);
    if (!j.is_object()) continue;
    if (j["type"] == "summary") summary = j;
    if (j["type"] == "asset") {
      ++asset_lines;
      EXPECT_EQ(j["status"], "succeeded") << j.dump();
      EXPECT_EQ(j["cached"], false) << j.dump();
    }
  }
  EXPECT_EQ(asset_lines, kAssets) << out;
  EXPECT_EQ(summary["total"], kAssets) << out;
  EXPECT_EQ(summary["succeeded"], kAssets) << out;
  EXPECT_EQ(summary["baked"], kAssets) << out;
  EXPECT_EQ(summary["cached"], 0) << out;
  EXPECT_EQ(server.process().CountInLog("event=complete job="), kAssets) << log;
  std::printf("bake-batch of %d assets: at most %d watch streams, %zu opened in all\n", kAssets, batch_max,
              batch_opened);
}

}  // namespace
}  // namespace impostor
