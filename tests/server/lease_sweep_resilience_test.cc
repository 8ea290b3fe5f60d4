// The lease sweep on PostgreSQL stays right when the farm's surroundings go
// wrong: a database outage (heartbeats could not be recorded, so deadlines
// that passed meanwhile cost no attempt and a finished result is still
// accepted), a replica that hangs holding the maintenance role (another
// replica takes it over within a bounded time and expires the dead
// worker's lease), and a replica whose clock is wrong (lease deadlines and
// sweeps are on the database's clock, so it neither expires the others'
// leases nor writes deadlines already past).
//
// Real PostgreSQL servers (tests/support/postgres_instance.h), schedulers
// in-process so the test can stop a replica dead (a hung process keeps its
// session, exactly as one that stops calling does) and move its clocks.
#include <atomic>
#include <chrono>
#include <filesystem>
#include <functional>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "common/util/sha256.h"
#include "server/scheduler/bake_scheduler.h"
#include "tests/server/job_store_test_engines.h"

namespace impostor::testing {
namespace {

using Clock = std::chrono::steady_clock;
constexpr int64_t kLeaseTimeoutMs = 30'000;

int64_t SystemMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// Polls `done` (each poll may do work, e.g. a sweep) until it is true or
// `limit` passes; whether it became true.
bool WaitFor(std::chrono::milliseconds limit, const std::function<bool()>& done) {
  const auto give_up = Clock::now() + limit;
  while (!done()) {
    if (Clock::now() > give_up) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return true;
}

// A blob directory and what workers upload to it.
class Uploads {
 public:
  explicit Uploads(const std::string& name)
      : dir_(std::filesystem::temp_directory_path() / (name + "_" + std::to_string(::getpid()))) {
    std::filesystem::remove_all(dir_);
    auto blobs = BlobStore::Open(dir_);
    EXPECT_TRUE(blobs.ok()) << blobs.status();
    if (blobs.ok()) blobs_ = std::move(*blobs);
  }
  ~Uploads() { std::filesystem::remove_all(dir_); }
  BlobStore* blobs() { return blobs_.get(); }
  v1::Digest Put(const std::string& bytes) {
    v1::Digest d;
    d.set_hash(Sha256Hex(bytes));
    d.set_size_bytes(static_cast<int64_t>(bytes.size()));
    EXPECT_TRUE(blobs_->Put({d.hash(), d.size_bytes()}, bytes).ok());
    return d;
  }
  v1::SubmitBakeRequest Request(const std::string& mesh) {
    v1::SubmitBakeRequest r;
    r.mutable_mesh()->mutable_entry()->set_path("model.glb");
    *r.mutable_mesh()->mutable_entry()->mutable_digest() = Put(mesh);
    return r;
  }
  v1::CompleteJobRequest Result(const v1::LeasedJob& job) {
    v1::CompleteJobRequest r;
    r.set_job_id(job.job_id());
    r.set_lease_id(job.lease_id());
    r.mutable_result()->set_cache_key(job.cache_key());
    *r.mutable_result()->mutable_manifest_json() = Put("{\"manifest\": true}");
    v1::MapFile* map = r.mutable_result()->add_maps();
    map->set_file("albedo_alpha.png");
    *map->mutable_digest() = Put("png " + job.cache_key());
    return r;
  }

 private:
  std::filesystem::path dir_;
  std::unique_ptr<BlobStore> blobs_;
};

std::optional<v1::LeasedJob> LeaseOne(BakeScheduler& replica, const std::string& worker) {
  v1::LeaseJobRequest r;
  r.set_worker_id(worker);
  auto job = replica.Lease(r, Clock::now(), nullptr);
  EXPECT_TRUE(job.ok()) << job.status();
  return job.ok() ? *job : std::nullopt;
}

v1::JobState StateOf(BakeScheduler& replica, const std::string& job_id) {
  auto job = replica.GetJob(job_id);
  EXPECT_TRUE(job.ok()) << job.status();
  return job.ok() ? job->state() : v1::JOB_STATE_UNSPECIFIED;
}

// Defect: after a 30 s PostgreSQL outage the sweep expired every running
// lease 0.1 s after the database came back, refused the finished results
// and baked them again as attempt 2.
TEST(LeaseSweepAcrossOutage, DeadlinesThatPassedWhileTheDatabaseWasDownCostNoAttempt) {
  auto pg = PostgresInstance::Start();  // its own: it is stopped below
  ASSERT_TRUE(pg.ok()) << pg.status();
  ASSERT_TRUE((*pg)->CreateDatabase("jobs").ok());
  auto store = PostgresJobStore::Open({.url = (*pg)->Url("jobs"), .pool_size = 2, .reconnect_window_ms = 500});
  ASSERT_TRUE(store.ok()) << store.status();
  Uploads uploads("lease_sweep_outage");
  std::atomic<int64_t> now_ms{SystemMs()};  // moved by hand: the outage outlasts the lease
  BakeScheduler scheduler(store->get(), uploads.blobs(),
                          {.lease_timeout_ms = kLeaseTimeoutMs, .now_ms = [&] { return now_ms.load(); }});
  ASSERT_TRUE(scheduler.Submit(uploads.Request("finished during the outage"), "client").ok());
  ASSERT_TRUE(scheduler.Submit(uploads.Request("its worker died during the outage"), "client").ok());
  auto finished = LeaseOne(scheduler, "w-finished");
  auto abandoned = LeaseOne(scheduler, "w-dead");
  ASSERT_TRUE(finished.has_value() && abandoned.has_value());
  ASSERT_TRUE(scheduler.ExpireLeases().ok());  // this replica sweeps

  ASSERT_TRUE((*pg)->Stop().ok());
  // The worker's heartbeat cannot be recorded, nor can the sweep run...
  v1::ReportProgressRequest beat;
  beat.set_job_id(finished->job_id());
  beat.set_lease_id(finished->lease_id());
  beat.set_progress(0.9f);
  EXPECT_FALSE(scheduler.ReportProgress(beat).ok());
  EXPECT_FALSE(scheduler.ExpireLeases().ok());
  // ...while both leases' deadlines pass.
  now_ms += kLeaseTimeoutMs + 1000;
  ASSERT_TRUE((*pg)->StartAgain().ok());

  // The first sweeps once the database answers expire nothing.
  ASSERT_TRUE(WaitFor(std::chrono::seconds(30), [&] { return scheduler.ExpireLeases().ok(); }));
  ASSERT_TRUE(scheduler.ExpireLeases().ok());
  EXPECT_EQ(StateOf(scheduler, abandoned->job_id()), v1::JOB_STATE_RUNNING);
  // The result uploaded during the outage is accepted under its lease.
  ASSERT_TRUE(scheduler.Complete(uploads.Result(*finished)).ok());
  auto done = scheduler.GetJob(finished->job_id());
  ASSERT_TRUE(done.ok()) << done.status();
  EXPECT_EQ(done->state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(done->attempts(), 1u);

  // A worker that really died is still noticed, one lease timeout after
  // the database came back.
  now_ms += kLeaseTimeoutMs + 1000;
  ASSERT_TRUE(scheduler.ExpireLeases().ok());
  auto requeued = scheduler.GetJob(abandoned->job_id());
  ASSERT_TRUE(requeued.ok()) << requeued.status();
  EXPECT_EQ(requeued->state(), v1::JOB_STATE_QUEUED);
  EXPECT_EQ(requeued->attempts(), 1u);
}

// Two replicas on one database with a shared virtual clock, and what the
// database says about the maintenance role.
class TwoReplicas {
 public:
  explicit TwoReplicas(const std::string& name, int64_t takeover_ms = 30'000) : uploads_(name) {
    url_ = FreshPostgresDatabase();
    EXPECT_FALSE(url_.empty());
    for (int i = 0; i < 2; ++i) {
      auto store = PostgresJobStore::Open({.url = url_, .pool_size = 2, .maintenance_takeover_ms = takeover_ms});
      EXPECT_TRUE(store.ok()) << store.status();
      if (!store.ok()) return;
      stores_[i] = std::move(*store);
      replicas_[i] = std::make_unique<BakeScheduler>(
          stores_[i].get(), uploads_.blobs(),
          SchedulerOptions{.lease_timeout_ms = kLeaseTimeoutMs, .now_ms = [this] { return now_ms_.load(); }});
    }
  }
  bool ok() const { return replicas_[1] != nullptr; }
  BakeScheduler& replica(int i) { return *replicas_[i]; }
  JobStore& store(int i) { return *stores_[i]; }
  Uploads& uploads() { return uploads_; }
  void Advance(int64_t ms) { now_ms_ += ms; }

 private:
  Uploads uploads_;
  std::string url_;
  std::atomic<int64_t> now_ms_{SystemMs()};
  std::unique_ptr<JobStore> stores_[2];
  std::unique_ptr<BakeScheduler> replicas_[2];
};

// Defect: a replica stopped with SIGSTOP kept its session and with it the
// maintenance lock, so no lease expired anywhere until it was continued.
TEST(MaintenanceTakeover, AHungHolderLosesTheRoleAndAnotherReplicaExpiresTheDeadWorkersLease) {
  constexpr int64_t kTakeoverMs = 2000;
  TwoReplicas farm("maintenance_takeover", kTakeoverMs);
  ASSERT_TRUE(farm.ok());
  BakeScheduler& hung = farm.replica(0);
  BakeScheduler& healthy = farm.replica(1);
  ASSERT_TRUE(hung.ExpireLeases().ok());
  ASSERT_TRUE(*farm.store(0).HoldMaintenanceLock());
  // A holder that renews keeps the role.
  ASSERT_FALSE(*farm.store(1).HoldMaintenanceLock());

  ASSERT_TRUE(healthy.Submit(farm.uploads().Request("its worker was killed"), "client").ok());
  auto leased = LeaseOne(healthy, "w-killed");
  ASSERT_TRUE(leased.has_value());
  // From here replica 0 makes no call (hung, its session open), the worker
  // never reports again, and its lease runs out.
  farm.Advance(kLeaseTimeoutMs + 1000);
  const auto hung_at = Clock::now();
  EXPECT_TRUE(WaitFor(std::chrono::seconds(20), [&] {
    EXPECT_TRUE(healthy.ExpireLeases().ok());
    return StateOf(healthy, leased->job_id()) == v1::JOB_STATE_QUEUED;
  })) << "the healthy replica never took the sweep over";
  const double seconds = std::chrono::duration<double>(Clock::now() - hung_at).count();
  EXPECT_GE(seconds, kTakeoverMs / 1000.0 * 0.5) << "taken over before the holder was stale";
  EXPECT_LT(seconds, 15.0);
  auto job = healthy.GetJob(leased->job_id());
  ASSERT_TRUE(job.ok());
  EXPECT_EQ(job->attempts(), 1u);
  EXPECT_TRUE(*farm.store(1).HoldMaintenanceLock());
  // The hung replica, continued, finds it has lost the role.
  auto resumed = farm.store(0).HoldMaintenanceLock();
  ASSERT_TRUE(resumed.ok()) << resumed.status();
  EXPECT_FALSE(*resumed);
}

// Defect: one replica's clock 60 s ahead, holding the sweep, expired every
// other replica's leases; one behind wrote deadlines already past.
TEST(SharedLeaseClock, AReplicaWithAWrongClockNeitherExpiresNorShortensAnothersLease) {
  struct Case {
    const char* name;
    int64_t leaser_skew_ms;
    int64_t sweeper_skew_ms;
  };
  const Case cases[] = {
      {"the sweeping replica's clock 60 s ahead", 0, 60'000},
      {"the leasing replica's clock 60 s behind", -60'000, 0},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string url = FreshPostgresDatabase();
    ASSERT_FALSE(url.empty());
    Uploads uploads("shared_lease_clock");
    // Each replica's "system clock" (the engine's and the scheduler's),
    // wrong by its skew, as a host with a wrong time has it.
    auto open = [&](int64_t skew) {
      std::function<int64_t()> clock = [skew] { return SystemMs() + skew; };
      auto store = PostgresJobStore::Open({.url = url, .pool_size = 2, .local_clock_ms = clock});
      EXPECT_TRUE(store.ok()) << store.status();
      return std::move(*store);
    };
    auto leaser_store = open(c.leaser_skew_ms);
    auto sweeper_store = open(c.sweeper_skew_ms);
    BakeScheduler leaser(leaser_store.get(), uploads.blobs(),
                         {.lease_timeout_ms = kLeaseTimeoutMs, .now_ms = [&] { return SystemMs() + c.leaser_skew_ms; }});
    BakeScheduler sweeper(sweeper_store.get(), uploads.blobs(),
                          {.lease_timeout_ms = kLeaseTimeoutMs,
                           .now_ms = [&] { return SystemMs() + c.sweeper_skew_ms; }});
    ASSERT_TRUE(sweeper.ExpireLeases().ok());
    ASSERT_TRUE(*sweeper_store->HoldMaintenanceLock());

    ASSERT_TRUE(leaser.Submit(uploads.Request(c.name), "client").ok());
    auto leased = LeaseOne(leaser, "w-healthy");
    ASSERT_TRUE(leased.has_value());
    // The deadline is a lease timeout from now on the database's clock
    // (here the true time), whatever the leasing host believes.
    EXPECT_NEAR(static_cast<double>(leased->lease_deadline_ms()), static_cast<double>(SystemMs() + kLeaseTimeoutMs),
                5000.0);
    ASSERT_TRUE(sweeper.ExpireLeases().ok());
    EXPECT_EQ(StateOf(sweeper, leased->job_id()), v1::JOB_STATE_RUNNING);
    ASSERT_TRUE(leaser.Complete(uploads.Result(*leased)).ok());
    auto job = leaser.GetJob(leased->job_id());
    ASSERT_TRUE(job.ok());
    EXPECT_EQ(job->state(), v1::JOB_STATE_SUCCEEDED);
    EXPECT_EQ(job->attempts(), 1u);
  }
}

}  // namespace
}  // namespace impostor::testing
