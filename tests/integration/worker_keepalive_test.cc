// impostor-worker's --keepalive-seconds (issue 15): a blob transfer whose
// link goes dark (a cut cable: here TcpProxy::GoDarkAfter, which drops
// every byte both ways and passes on no close, so that neither kernel gives
// up by itself) is given up after about keepalive + min(keepalive, 10) s and
// retried, instead of waiting out the stream's 10-minute deadline; and its
// bad values are usage errors.
#include <chrono>
#include <string>

#include <gtest/gtest.h>

#include "tests/integration/farm_processes.h"
#include "tests/support/server_process.h"
#include "tests/support/tcp_proxy.h"

namespace impostor {
namespace {

using testing::AssetsDir;
using testing::ServerProcess;
using testing::TcpProxy;

constexpr char kBoxTextured[] = "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb";
// Bounds for a loaded machine: the worker reaching the frozen point, and
// it giving the frozen stream up (2 + 2 s at --keepalive-seconds=2; the
// stream's own deadline is 600 s, so without pings this fails).
constexpr auto kFreezeDeadline = std::chrono::seconds(120);
constexpr auto kGiveUpDeadline = std::chrono::seconds(60);

TEST(WorkerKeepalive, AnInputDownloadThatStopsAnsweringIsRetriedWithinTheKeepalive) {
  ServerProcess server(0);
  // The model and a 3 MiB input the worker must download too; the link
  // goes dark a third of the way into it.
  const v1::SubmitBakeResponse submitted =
      testing::SubmitWithPaddedInput(server, AssetsDir() / kBoxTextured, 3 << 20, 23);

  TcpProxy proxy(server.address());
  proxy.GoDarkAfter(1 << 20, TcpProxy::Direction::kToClient);
  auto worker = testing::StartWorker(proxy.address(), "keepalive-worker",
                                     {"--max-jobs=1", "--max-outage-seconds=120", "--keepalive-seconds=2",
                                      "--log-level=info"});
  ASSERT_TRUE(proxy.WaitFrozen(kFreezeDeadline)) << "the worker never got 1 MiB into its inputs";
  // The worker's pings go unanswered: it gives the connection up and
  // retries the download (a retry that waits for the link, like this one).
  EXPECT_TRUE(worker->WaitForLog("event=rpc_retry rpc=ReadBlob", 1, kGiveUpDeadline)) << worker->Stderr();

  // The link heals: the bake finishes.
  proxy.CutAll();
  const v1::Job done = testing::WatchToEnd(server.bake(), submitted.job_id());
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.DebugString();
  EXPECT_EQ(worker->Wait(), 0) << worker->Stderr();
}

TEST(WorkerKeepalive, OutOfRangeValuesAreUsageErrorsNamingTheFlag) {
  for (const char* flag : {"--keepalive-seconds=0", "--keepalive-seconds=-3", "--keepalive-seconds=7201"}) {
    auto worker = testing::StartWorker("127.0.0.1:1", "bad-keepalive", {flag});
    EXPECT_EQ(worker->Wait(), 2) << flag;
    EXPECT_NE(worker->Stderr().find("--keepalive-seconds: "), std::string::npos) << worker->Stderr();
    EXPECT_NE(worker->Stderr().find("is out of range 1..7200"), std::string::npos) << worker->Stderr();
  }
}

}  // namespace
}  // namespace impostor
