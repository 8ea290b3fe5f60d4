// A mixed farm on one server (SQLite), real processes (issue 44): three
// lavapipe workers of different (test-reported) host memory and tags, bakes
// of three sizes, each landing only on a worker that holds it, none failed
// for a worker's size; a bake no worker holds waits with its reason and
// fails after --unplaceable-timeout-seconds, as a placement decision (no
// attempt). tests/integration/mixed_farm_postgres_test.cc runs the same farm
// on two replicas over PostgreSQL.
#include <gtest/gtest.h>

#include "tests/integration/mixed_farm.h"

namespace impostor::testing {
namespace {

using namespace mixed_farm;

TEST(MixedFarm, BakesOfThreeSizesLandOnlyOnWorkersThatHoldThemAndTheImpossibleOneFailsAfterTheTimeout) {
  ServerProcess server(0, {"--unplaceable-timeout-seconds=2"});
  const v1::MeshInput mesh =
      UploadGlb(server.assets(), AssetsDir() / "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb");
  std::vector<Bake> bakes = Bakes(mesh);
  // Submitted before any worker is about, so every worker sees the whole
  // queue and the first to ask could take any job it were allowed to.
  for (Bake& b : bakes) b.job_id = Submit(server, b.request);
  std::vector<std::unique_ptr<ChildProcess>> workers;
  for (const Worker& w : Workers()) workers.push_back(StartFarmWorker(server.address(), w));

  v1::SubmitBakeRequest impossible;
  *impossible.mutable_mesh() = mesh;
  *impossible.mutable_parameters() = Params(kImpossible, 4);
  const std::string impossible_id = Submit(server, impossible);
  WaitsWithItsReason(server.bake(), impossible_id);

  ExpectEachLandedWhereItFits(server.bake(), bakes);

  const v1::Job failed = WatchToEnd(server.bake(), impossible_id);
  ASSERT_EQ(failed.state(), v1::JOB_STATE_FAILED) << failed.DebugString();
  EXPECT_EQ(failed.attempts(), 0u);  // a placement decision, never a failed attempt
  EXPECT_EQ(failed.error().code(), static_cast<int32_t>(absl::StatusCode::kResourceExhausted));
  EXPECT_EQ(failed.error().message().rfind("no worker could bake it for 2 s (--unplaceable-timeout-seconds): "
                                           "waiting for a worker with at least ",
                                           0),
            0u)
      << failed.error().message();
}

}  // namespace
}  // namespace impostor::testing
