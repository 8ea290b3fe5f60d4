// Pools and shares (issue 44): a team with a share of a pool gets at least
// that share of the pool's workers while it has work, whatever the usual
// fairness would give it. 200 small bakes from two teams run through a
// pool of four workers per server with a fake clock and explicit Lease / Complete
// calls (no sleeps): on SQLite, on PostgreSQL, and on two PostgreSQL
// replicas that each hear from half of the pool's workers.
//
// Without the share the usual order (fewest running first) splits the pool
// 2:2, and these tests fail (team-forest gets 50 %, not 75 %).
#include <unistd.h>

#include <chrono>
#include <deque>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "common/util/sha256.h"
#include "server/scheduler/bake_scheduler.h"
#include "tests/server/job_store_test_engines.h"

namespace impostor::testing {
namespace {

constexpr int kBakesPerTeam = 100;
constexpr int kPoolWorkers = 4;
constexpr int kForestPercent = 75;
constexpr double kTolerance = 0.10;

// team-forest submits with a token (owner "team-forest", client id
// "team-forest/10.0.0.7", as bake_service.cc names it); team-desert without
// one (client id "team-desert"): a share matches either.
struct Team {
  const char* name;
  const char* client_id;
  const char* owner;
};
constexpr Team kForest{"team-forest", "team-forest/10.0.0.7", "team-forest"};
constexpr Team kDesert{"team-desert", "team-desert", ""};

std::vector<WorkerPool> GpuPool(bool with_share) {
  std::vector<WorkerPool> pools{{.name = "gpu", .tag = "gpu", .shares = {}}};
  if (with_share) pools[0].shares.push_back({.team = kForest.name, .percent = kForestPercent});
  return pools;
}

class PoolShareRun : public ::testing::Test {
 protected:
  void TearDown() override {
    replicas_.clear();
    stores_.clear();
    blobs_.reset();
    if (!dir_.empty()) std::filesystem::remove_all(dir_);
  }
  // `replicas` schedulers over one store of `engine` ("sqlite": one only),
  // and a blob directory they share.
  void Start(const std::string& engine, int replicas, const std::vector<WorkerPool>& pools) {
    dir_ = std::filesystem::temp_directory_path() /
           absl::StrCat("pool_share_", ::getpid(), "_",
                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    auto blobs = BlobStore::Open(dir_ / "blobs");
    ASSERT_TRUE(blobs.ok()) << blobs.status();
    blobs_ = std::move(*blobs);
    const std::string url = engine == "postgresql" ? FreshPostgresDatabase() : "";
    if (engine == "postgresql") {
      ASSERT_FALSE(url.empty());
    }
    for (int i = 0; i < replicas; ++i) {
      absl::StatusOr<std::unique_ptr<JobStore>> store;
      if (engine == "postgresql") {
        auto pg = PostgresJobStore::Open({.url = url, .pool_size = 2});
        ASSERT_TRUE(pg.ok()) << pg.status();
        store = std::unique_ptr<JobStore>(std::move(*pg));
      } else {
        ASSERT_EQ(replicas, 1);
        store = JobStore::Open(dir_ / "jobs.sqlite3");
      }
      ASSERT_TRUE(store.ok()) << store.status();
      stores_.push_back(std::move(*store));
      replicas_.push_back(std::make_unique<BakeScheduler>(
          stores_.back().get(), blobs_.get(),
          SchedulerOptions{.lease_timeout_ms = 30'000,
                           .max_attempts = 3,
                           .prefer_strong_ms = 0,
                           .pools = pools,
                           .now_ms = [this] { return now_ms_; }}));
    }
  }
  v1::Digest Store(const std::string& bytes) {
    v1::Digest d;
    d.set_hash(Sha256Hex(bytes));
    d.set_size_bytes(static_cast<int64_t>(bytes.size()));
    EXPECT_TRUE(blobs_->Put({d.hash(), d.size_bytes()}, bytes).ok());
    return d;
  }
  void Submit(const Team& team, int i, int32_t priority) {
    v1::SubmitBakeRequest r;
    r.set_priority(priority);
    r.mutable_mesh()->mutable_entry()->set_path("model.glb");
    *r.mutable_mesh()->mutable_entry()->mutable_digest() = Store(absl::StrCat(team.name, " model ", i));
    r.mutable_parameters()->set_resolution(256);  // small: goes anywhere
    auto submitted = replicas_[0]->Submit(r, team.client_id, team.owner);
    ASSERT_TRUE(submitted.ok()) << submitted.status();
    team_of_[submitted->job_id()] = team.name;
    ++now_ms_;
  }
  // One LeaseJob that does not wait, by a worker tagged `tag`; nothing when
  // the queue is empty.
  std::optional<v1::LeasedJob> Lease(int replica, const std::string& worker, const std::string& tag) {
    v1::LeaseJobRequest r;
    r.set_worker_id(worker);
    v1::WorkerCapabilities* caps = r.mutable_capabilities();
    caps->set_device_kind("discrete");
    caps->set_host_memory_bytes(int64_t{64} << 30);
    caps->set_ktx2_encoder(true);
    caps->set_baker_version("test");
    caps->add_tags(tag);
    auto job = replicas_[replica]->Lease(r, std::chrono::steady_clock::now(), nullptr);
    EXPECT_TRUE(job.ok()) << job.status();
    return job.ok() ? *job : std::nullopt;
  }
  void Complete(int replica, const v1::LeasedJob& job) {
    v1::CompleteJobRequest r;
    r.set_job_id(job.job_id());
    r.set_lease_id(job.lease_id());
    r.mutable_result()->set_cache_key(job.cache_key());
    *r.mutable_result()->mutable_manifest_json() = Store("{\"manifest\": true}");
    v1::MapFile* map = r.mutable_result()->add_maps();
    map->set_file("albedo_alpha.png");
    *map->mutable_digest() = Store("png " + job.cache_key());
    ASSERT_TRUE(replicas_[replica]->Complete(r).ok());
  }

  // What a run measured: of the leases the pool's workers took while both
  // teams still had work queued, team-forest's fraction; and every bake
  // done.
  struct Outcome {
    double forest_fraction = 0;
    int contested_leases = 0;
    int completed = 0;
  };
  // Submits kBakesPerTeam bakes for each team, team-desert's first (so the
  // usual order would favour it), at `desert_priority` (team-forest's are
  // at 0), then runs the pool: kPoolWorkers gpu
  // workers per replica, worker i polling replica i % replicas, and one
  // untagged worker outside
  // the pool (its leases are not the pool's). Each step the longest-running
  // bake completes and its worker asks again.
  Outcome Run(int32_t desert_priority = 0) {
    for (int i = 0; i < kBakesPerTeam; ++i) Submit(kDesert, i, desert_priority);
    for (int i = 0; i < kBakesPerTeam; ++i) Submit(kForest, i, 0);
    const int replicas = static_cast<int>(replicas_.size());
    struct Held {
      int replica;
      std::string worker;
      std::string tag;
      v1::LeasedJob job;
    };
    std::deque<Held> running;  // oldest lease first
    std::map<std::string, int> queued{{kForest.name, kBakesPerTeam}, {kDesert.name, kBakesPerTeam}};
    std::map<std::string, int> pool_leases;
    Outcome out;
    auto lease = [&](int replica, const std::string& worker, const std::string& tag) {
      const bool contested = queued[kForest.name] > 0 && queued[kDesert.name] > 0;
      auto job = Lease(replica, worker, tag);
      if (!job || job->job_id().empty()) return;
      const std::string& team = team_of_.at(job->job_id());
      --queued[team];
      if (contested && tag == "gpu") {
        ++pool_leases[team];
        ++out.contested_leases;
      }
      running.push_back({replica, worker, tag, *job});
      ++now_ms_;
    };
    for (int w = 0; w < kPoolWorkers * replicas; ++w) lease(w % replicas, absl::StrCat("gpu-", w), "gpu");
    lease(0, "cpu-0", "cpu");
    while (!running.empty()) {
      Held done = running.front();
      running.pop_front();
      Complete(done.replica, done.job);
      ++out.completed;
      ++now_ms_;
      lease(done.replica, done.worker, done.tag);
    }
    if (out.contested_leases > 0) {
      out.forest_fraction = static_cast<double>(pool_leases[kForest.name]) / out.contested_leases;
    }
    return out;
  }

  std::filesystem::path dir_;
  // Starts at the real time, as the database's clock reads.
  int64_t now_ms_ = std::chrono::duration_cast<std::chrono::milliseconds>(
                        std::chrono::system_clock::now().time_since_epoch())
                        .count();
  std::unique_ptr<BlobStore> blobs_;
  std::vector<std::unique_ptr<JobStore>> stores_;
  std::vector<std::unique_ptr<BakeScheduler>> replicas_;
  std::map<std::string, std::string> team_of_;  // job id -> team
};

void ExpectShareHolds(const char* what, double fraction, int contested, int completed) {
  EXPECT_EQ(completed, 2 * kBakesPerTeam) << what;
  EXPECT_GE(contested, 100) << what << ": too few leases while both teams had work to measure a share";
  EXPECT_NEAR(fraction, kForestPercent / 100.0, kTolerance)
      << what << ": team-forest's fraction of pool gpu's leases over " << contested
      << " leases while both teams had work";
}

TEST_F(PoolShareRun, TeamForestGetsItsShareOfThePoolOnSqlite) {
  Start("sqlite", 1, GpuPool(true));
  const Outcome out = Run();
  ExpectShareHolds("sqlite", out.forest_fraction, out.contested_leases, out.completed);
  std::printf("sqlite: team-forest %.3f of %d contested pool leases\n", out.forest_fraction, out.contested_leases);
}

TEST_F(PoolShareRun, TeamForestGetsItsShareOfThePoolOnPostgresql) {
  Start("postgresql", 1, GpuPool(true));
  const Outcome out = Run();
  ExpectShareHolds("postgresql", out.forest_fraction, out.contested_leases, out.completed);
  std::printf("postgresql: team-forest %.3f of %d contested pool leases\n", out.forest_fraction,
              out.contested_leases);
}

// Each replica hears from four of the pool's eight workers and guarantees
// the share over those (3 of 4), so the pool as a whole holds it; the
// running jobs are counted from the one database.
TEST_F(PoolShareRun, TeamForestGetsItsShareAcrossTwoPostgresqlReplicas) {
  Start("postgresql", 2, GpuPool(true));
  const Outcome out = Run();
  ExpectShareHolds("two replicas", out.forest_fraction, out.contested_leases, out.completed);
  std::printf("two replicas: team-forest %.3f of %d contested pool leases\n", out.forest_fraction,
              out.contested_leases);
}

// A share is a guarantee: team-desert's bakes at a higher priority do not
// take team-forest's share (without it, team-forest would get nothing while
// team-desert has work).
TEST_F(PoolShareRun, TeamForestGetsItsShareOverTeamDesertsHigherPriority) {
  Start("sqlite", 1, GpuPool(true));
  const Outcome out = Run(/*desert_priority=*/5);
  ExpectShareHolds("desert at priority 5", out.forest_fraction, out.contested_leases, out.completed);
  std::printf("desert at priority 5: team-forest %.3f of %d contested pool leases\n", out.forest_fraction,
              out.contested_leases);
}

TEST_F(PoolShareRun, TeamForestGetsItsShareOverTeamDesertsHigherPriorityOnPostgresql) {
  Start("postgresql", 1, GpuPool(true));
  const Outcome out = Run(/*desert_priority=*/5);
  ExpectShareHolds("postgresql, desert at priority 5", out.forest_fraction, out.contested_leases, out.completed);
}

// The control: without the share the usual order splits the pool evenly,
// which is what makes the tests above able to fail.
TEST_F(PoolShareRun, WithoutTheShareThePoolSplitsEvenly) {
  Start("sqlite", 1, GpuPool(false));
  const Outcome out = Run();
  EXPECT_EQ(out.completed, 2 * kBakesPerTeam);
  EXPECT_NEAR(out.forest_fraction, 0.5, kTolerance);
  Outcome by_priority;
  TearDown();
  Start("sqlite", 1, GpuPool(false));
  team_of_.clear();
  by_priority = Run(/*desert_priority=*/5);
  EXPECT_EQ(by_priority.forest_fraction, 0.0) << "priority first: team-desert's bakes all go before";
}

}  // namespace
}  // namespace impostor::testing
