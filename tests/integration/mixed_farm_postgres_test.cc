// The mixed farm of mixed_farm_test.cc on two replicas sharing a PostgreSQL
// database and a blob directory (issue 44): the small and medium workers
// poll replica A, the large one replica B; every bake is submitted to A.
// The large bakes, which no worker of A holds, wait on A with their reason
// and are baked through B; nothing fails for a worker's size. The bake no
// worker holds waits with its reason and, with replicas, is never failed as
// unplaceable: a replica knows only the workers that poll it, so it cannot
// tell that no worker anywhere holds the job (docs/guides/mixed-farm.md).
#include <gtest/gtest.h>

#include "tests/integration/mixed_farm.h"
#include "tests/support/postgres_instance.h"

namespace impostor::testing {
namespace {

using namespace mixed_farm;

TEST(MixedFarmReplicas, BakesLandOnlyOnWorkersThatHoldThemThroughEitherReplica) {
  auto pg = PostgresInstance::Start();
  ASSERT_TRUE(pg.ok()) << pg.status();
  ASSERT_TRUE((*pg)->CreateDatabase("farm").ok());
  const std::filesystem::path blobs = NewTempDir("mixed_farm_blobs");
  const std::vector<std::string> args = {"--database=" + (*pg)->Url("farm"), "--blob-dir=" + blobs.string(),
                                         "--unplaceable-timeout-seconds=2"};
  ServerProcess a(0, args);
  ServerProcess b(0, args);
  const v1::MeshInput mesh = UploadGlb(a.assets(), AssetsDir() / "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb");
  std::vector<Bake> bakes = Bakes(mesh);
  for (Bake& bake : bakes) bake.job_id = Submit(a, bake.request);

  const std::vector<Worker> farm = Workers();
  std::vector<std::unique_ptr<ChildProcess>> workers;
  workers.push_back(StartFarmWorker(a.address(), farm[0]));
  workers.push_back(StartFarmWorker(a.address(), farm[1]));
  v1::SubmitBakeRequest impossible;
  *impossible.mutable_mesh() = mesh;
  *impossible.mutable_parameters() = Params(kImpossible, 4);
  const std::string impossible_id = Submit(a, impossible);
  // Before the large worker is about, replica A says why its large bakes wait.
  for (const Bake& bake : bakes) {
    if (bake.label.rfind("large", 0) == 0) WaitsWithItsReason(a.bake(), bake.job_id);
  }
  workers.push_back(StartFarmWorker(b.address(), farm[2]));

  ExpectEachLandedWhereItFits(a.bake(), bakes);

  // Every other bake is done and more than the 2 s timeout went by: still
  // queued, with its reason, no attempt.
  const v1::Job waiting = WaitsWithItsReason(a.bake(), impossible_id);
  EXPECT_EQ(waiting.state(), v1::JOB_STATE_QUEUED) << waiting.DebugString();
  auto ctx = ContextWithin();
  v1::CancelJobRequest cancel;
  cancel.set_job_id(impossible_id);
  v1::Job cancelled;
  ASSERT_TRUE(a.bake().CancelJob(ctx.get(), cancel, &cancelled).ok());
}

}  // namespace
}  // namespace impostor::testing
