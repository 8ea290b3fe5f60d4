// The farm across real network hosts (issue 15), made by the test itself
// with Linux network namespaces joined by a bridge (tests/support/netns.h):
//  - a server on one host, workers on two others and a client on a fourth
//    bake a real asset across the bridge;
//  - a client and a worker given two server replicas keep baking when one
//    replica's link is cut (a pulled cable: no reset, packets vanish), and
//    the result is byte-identical to the bake before the cut.
// Needs root; skipped with the reason otherwise. CTest label: netns.
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/integration/netns_fixture.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::AssetsDir;
using testing::BinaryDir;
using testing::ChildProcess;
using testing::TestNetwork;

constexpr char kBox[] = "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb";

class NetnsFarm : public testing::NetnsTest {
 protected:
  static void WriteFile(const fs::path& path, const std::string& text) { std::ofstream(path) << text << "\n"; }

  // impostor-server on `host`, ready (it printed "listening on").
  std::unique_ptr<ChildProcess> StartServer(const TestNetwork::Host& host, const fs::path& data) {
    testing::ProcessOptions options;
    options.name = "server-" + host.name;
    auto server = std::make_unique<ChildProcess>(
        net_->Exec(host, {(BinaryDir() / "impostor-server").string(), "--listen=" + Address(host),
                          "--data=" + data.string(), "--local-workers=0", "--log-level=info"}),
        options);
    EXPECT_NE(server->ReadLineContaining("listening on"), "") << "server on " << host.name << " did not start";
    return server;
  }

  testing::ToolRun Bake(const TestNetwork::Host& client, const std::string& servers, const fs::path& out) {
    return testing::RunTool(net_->Exec(client, {(BinaryDir() / "impostor").string(), "bake",
                                                (AssetsDir() / kBox).string(), "--out", out.string(), "--server",
                                                servers, "--token-file", (dir_ / "submitter.token").string(),
                                                "--frames=3", "--resolution=64", "--quality-views=0"}));
  }

  // Tokens for the workers and the client, in `data` (before its server starts).
  void CreateTokens(const fs::path& data) {
    fs::create_directories(data);
    WriteFile(dir_ / "worker.token", testing::CreateToken(data, "worker", "netns-workers"));
    WriteFile(dir_ / "submitter.token", testing::CreateToken(data, "submitter", "netns-client"));
  }
};

TEST_F(NetnsFarm, ClientBakesAcrossTheBridge) {
  const TestNetwork::Host server_host = Host("server");
  const TestNetwork::Host worker1 = Host("worker1");
  const TestNetwork::Host worker2 = Host("worker2");
  const TestNetwork::Host client = Host("client");
  const fs::path data = dir_ / "data";
  CreateTokens(data);
  auto server = StartServer(server_host, data);
  const std::string address = Address(server_host);
  auto w1 = StartWorker(worker1, address);
  auto w2 = StartWorker(worker2, address);

  const testing::ToolRun run = Bake(client, address, dir_ / "out");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(fs::exists(dir_ / "out" / "albedo_alpha.png"));
  // One of the workers on the other hosts baked it.
  EXPECT_EQ(w1->CountInLog("event=job_done") + w2->CountInLog("event=job_done"), 1)
      << w1->Stderr() << w2->Stderr();
  // The server saw the workers and the client from their own addresses.
  EXPECT_NE(server->Stderr().find(client.address), std::string::npos) << server->Stderr();
}

TEST_F(NetnsFarm, ClientAndWorkerFailOverWhenAReplicaLinkIsCut) {
  const TestNetwork::Host s1 = Host("replica1");
  const TestNetwork::Host s2 = Host("replica2");
  const TestNetwork::Host worker_host = Host("worker");
  const TestNetwork::Host client = Host("client");
  // Until the replicas share a PostgreSQL store, each has its own data
  // directory; the second starts as a copy of the first so the same tokens
  // work on both.
  CreateTokens(dir_ / "data1");
  fs::copy(dir_ / "data1", dir_ / "data2", fs::copy_options::recursive);
  auto r1 = StartServer(s1, dir_ / "data1");
  auto r2 = StartServer(s2, dir_ / "data2");
  const std::string a1 = Address(s1);
  const std::string a2 = Address(s2);
  const std::string both = a1 + "," + a2;
  auto worker = StartWorker(worker_host, both);

  const testing::ToolRun before = Bake(client, both, dir_ / "before");
  ASSERT_EQ(before.exit_code, 0) << before.err;

  ASSERT_TRUE(net_->SetLink(s1, false).ok());
  // Replica 1 is unreachable but never said so: the client's connect to it
  // times out and it moves on; the worker's lease poll times out and it
  // moves on too. The same bake is done again on replica 2.
  const testing::ToolRun after = Bake(client, both, dir_ / "after");
  ASSERT_EQ(after.exit_code, 0) << after.err << worker->Stderr();
  EXPECT_GE(worker->CountInLog("event=server_failover from=" + a1 + " to=" + a2), 1) << worker->Stderr();
  EXPECT_NE(r2->Stderr().find(client.address), std::string::npos) << r2->Stderr();
  for (const char* file : {"albedo_alpha.png", "normal_depth.png"}) {
    EXPECT_EQ(testing::ReadFileBytes(dir_ / "before" / file), testing::ReadFileBytes(dir_ / "after" / file)) << file;
  }
  ASSERT_TRUE(net_->SetLink(s1, true).ok());
}

}  // namespace
}  // namespace impostor
