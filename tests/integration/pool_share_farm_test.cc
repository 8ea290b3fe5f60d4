// Pool shares with real processes (issue 44's second proof): an
// impostor-server with --auth token, --pools gpu and --pool-shares
// gpu:team-forest=75, four lavapipe workers tagged gpu, and 200 small bakes,
// 100 from each team's token, all queued (interleaved, so first come first
// served would give each team half) before any worker starts. While both
// teams had work queued, team-forest's bakes must be 75 % (within 10 points)
// of the leases, read from the jobs' own attempt records. The scheduler-level
// runs (tests/server/pool_share_scheduling_test.cc) hold the same share on
// SQLite, PostgreSQL and two replicas with a fake clock.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;

fs::path WriteTokenFile(const fs::path& dir, const std::string& name, const std::string& token) {
  const fs::path path = dir / (name + ".token");
  std::ofstream(path) << token << "\n";
  fs::permissions(path, fs::perms::owner_read | fs::perms::owner_write);
  return path;
}

TEST(PoolShareFarm, TwoHundredBakesFromTwoTeamsHoldTheShareWithinTenPoints) {
  ServerProcess server(0, {"--auth=token", "--pools=gpu", "--pool-shares=gpu:team-forest=75"});
  const fs::path dir = NewTempDir("pool_share_farm");
  const std::string forest = CreateToken(server.data_dir(), "submitter", "team-forest");
  const std::string desert = CreateToken(server.data_dir(), "submitter", "team-desert");
  ASSERT_FALSE(forest.empty() || desert.empty());

  server.UseToken(forest);
  const v1::MeshInput mesh = UploadGlb(server.assets(), AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb");
  // 100 distinct requests per team, the same sizes for both (frames 3..12 x
  // ten resolutions; the teams' resolutions 4 px apart so no key is shared).
  struct Submitted {
    std::string job_id;
    bool forest = false;
  };
  std::vector<Submitted> jobs;
  for (int i = 0; i < 100; ++i) {
    for (const bool is_forest : {true, false}) {
      server.UseToken(is_forest ? forest : desert);
      v1::SubmitBakeRequest request;
      *request.mutable_mesh() = mesh;
      request.mutable_parameters()->set_frames(3 + i % 10);
      request.mutable_parameters()->set_resolution(128 + 8 * (i / 10) + (is_forest ? 0 : 4));
      request.mutable_parameters()->set_quality_views(0);
      auto ctx = ContextWithin();
      v1::SubmitBakeResponse response;
      const grpc::Status s = server.bake().SubmitBake(ctx.get(), request, &response);
      ASSERT_TRUE(s.ok()) << s.error_message();
      ASSERT_FALSE(response.cached());
      jobs.push_back({response.job_id(), is_forest});
    }
  }

  std::vector<std::unique_ptr<ChildProcess>> workers;
  for (int w = 0; w < 4; ++w) {
    const std::string name = "gpu-node-" + std::to_string(w);
    const std::string token = CreateToken(server.data_dir(), "worker", name);
    ASSERT_FALSE(token.empty());
    workers.push_back(StartWorker(server.address(), {"--name=" + name, "--tags=gpu",
                                                     "--token-file=" + WriteTokenFile(dir, name, token).string()}));
  }

  // Each job's lease time, in the order the workers were given them (read
  // as an admin: a submitter sees only its own jobs).
  const std::string admin = CreateToken(server.data_dir(), "admin", "watcher");
  ASSERT_FALSE(admin.empty());
  server.UseToken(admin);
  std::vector<std::pair<int64_t, bool>> leases;
  for (const Submitted& j : jobs) {
    const v1::Job done = WatchToEnd(server.bake(), j.job_id);
    ASSERT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
    ASSERT_GE(done.attempt_history_size(), 1);
    leases.emplace_back(done.attempt_history(0).leased_ms(), j.forest);
  }
  std::stable_sort(leases.begin(), leases.end());
  // Up to the lease that took a team's last queued job, both had work.
  int forest_leases = 0, desert_leases = 0;
  for (const auto& [when, is_forest] : leases) {
    (is_forest ? forest_leases : desert_leases) += 1;
    if (forest_leases == 100 || desert_leases == 100) break;
  }
  const double share = static_cast<double>(forest_leases) / (forest_leases + desert_leases);
  std::printf("team-forest: %d of %d leases while both teams had work (%.3f; share 0.75)\n", forest_leases,
              forest_leases + desert_leases, share);
  EXPECT_NEAR(share, 0.75, 0.10);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace impostor::testing
