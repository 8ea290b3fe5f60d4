// Several head-node replicas behind one address list (issue 15), with real
// processes: `impostor bake --server DEAD,LIVE` bakes on the live replica;
// an impostor-worker given both replicas keeps baking on the second after
// the first is SIGKILLed under it; malformed lists fail at once naming
// --server. Until the replicas share a PostgreSQL store they do not share
// jobs, so these tests check the failover mechanics, not shared state.
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/integration/farm_processes.h"
#include "tests/support/server_process.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::AssetsDir;
using testing::BinaryDir;
using testing::ServerProcess;

constexpr char kBox[] = "props_pbr/Box/glTF-Binary/Box.glb";

std::string DeadAddress() { return "127.0.0.1:" + std::to_string(testing::FreeLoopbackPort()); }

TEST(Failover, CliBakeSkipsADeadFirstReplica) {
  ServerProcess live(1);
  const fs::path out = testing::NewTempDir("failover_cli") / "box";
  const testing::ToolRun run = testing::RunTool({(BinaryDir() / "impostor").string(), "bake",
                                                 (AssetsDir() / kBox).string(), "--out", out.string(), "--server",
                                                 DeadAddress() + "," + live.address(), "--frames=3",
                                                 "--resolution=64", "--quality-views=0"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(fs::exists(out / "manifest.json")) << run.out;
  EXPECT_TRUE(fs::exists(out / "albedo_alpha.png")) << run.out;
}

TEST(Failover, WorkerKeepsBakingOnTheOtherReplicaWhenItsServerIsKilled) {
  ServerProcess a(0), b(0);
  auto worker = testing::StartWorker(a.address() + "," + b.address(), "failover-worker", {"--log-level=info"});
  // A bake through replica A: the worker serves A first.
  const v1::MeshInput mesh_a = testing::UploadGlb(a.assets(), AssetsDir() / kBox);
  const v1::Job done_a = testing::WatchToEnd(a.bake(), testing::SubmitSmall(a.bake(), mesh_a).job_id());
  ASSERT_EQ(done_a.state(), v1::JOB_STATE_SUCCEEDED) << done_a.error().message();

  a.Kill();
  // Only B is left: the job queued there is leased by the same worker.
  const v1::MeshInput mesh_b = testing::UploadGlb(b.assets(), AssetsDir() / kBox);
  const v1::Job done_b = testing::WatchToEnd(b.bake(), testing::SubmitSmall(b.bake(), mesh_b).job_id());
  ASSERT_EQ(done_b.state(), v1::JOB_STATE_SUCCEEDED) << done_b.error().message();
  EXPECT_GE(worker->CountInLog("event=server_failover from=" + a.address() + " to=" + b.address()), 1)
      << worker->Stderr();
  EXPECT_TRUE(worker->Running()) << worker->Stderr();
}

TEST(Failover, MalformedListsFailAtOnceNamingTheFlag) {
  const testing::ToolRun worker = testing::RunTool(
      {(BinaryDir() / "impostor-worker").string(), "--server=127.0.0.1:1,,127.0.0.1:2"}, std::chrono::seconds(60));
  EXPECT_EQ(worker.exit_code, 2) << worker.err;
  EXPECT_NE(worker.err.find("--server: address 2 of \"127.0.0.1:1,,127.0.0.1:2\" is empty"), std::string::npos)
      << worker.err;

  // Without --server the worker takes $IMPOSTOR_SERVER, as the CLI does,
  // and names it when it is malformed.
  const testing::ToolRun from_env = testing::RunTool({(BinaryDir() / "impostor-worker").string()},
                                                     std::chrono::seconds(60), {"IMPOSTOR_SERVER=127.0.0.1:1,,"});
  EXPECT_EQ(from_env.exit_code, 2) << from_env.err;
  EXPECT_NE(from_env.err.find("$IMPOSTOR_SERVER: address 2 of \"127.0.0.1:1,,\" is empty"), std::string::npos)
      << from_env.err;

  const testing::ToolRun cli = testing::RunTool(
      {(BinaryDir() / "impostor").string(), "status", "job-1", "--server", "bake.lan,bake2.lan:50051"},
      std::chrono::seconds(60));
  EXPECT_NE(cli.exit_code, 0);
  EXPECT_NE(cli.err.find("--server: \"bake.lan\" has no port"), std::string::npos) << cli.err;
}

// A worker started with only $IMPOSTOR_SERVER (the systemd unit's
// Environment=, a container's env) goes to that server, not localhost:50051;
// --server wins over it.
TEST(Failover, WorkerTakesTheServerFromTheEnvironmentWithoutTheFlag) {
  const testing::ToolRun env_only =
      testing::RunTool({(BinaryDir() / "impostor-worker").string(), "--max-outage-seconds=1"},
                       std::chrono::seconds(60), {"IMPOSTOR_SERVER=127.0.0.1:1"});
  EXPECT_EQ(env_only.exit_code, 1) << env_only.err;
  EXPECT_NE(env_only.err.find("server 127.0.0.1:1 unreachable"), std::string::npos) << env_only.err;

  const testing::ToolRun flag_wins = testing::RunTool(
      {(BinaryDir() / "impostor-worker").string(), "--server=127.0.0.1:2", "--max-outage-seconds=1"},
      std::chrono::seconds(60), {"IMPOSTOR_SERVER=127.0.0.1:1"});
  EXPECT_EQ(flag_wins.exit_code, 1) << flag_wins.err;
  EXPECT_NE(flag_wins.err.find("server 127.0.0.1:2 unreachable"), std::string::npos) << flag_wins.err;
}

}  // namespace
}  // namespace impostor
