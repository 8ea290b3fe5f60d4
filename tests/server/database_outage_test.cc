// A PostgreSQL outage as the farm's observers see it: readiness and the
// read-only views (the dashboard, /metrics) answer within the probe's
// budget, instead of queueing behind a statement that waits out its
// reconnect window with the scheduler's lock held; the statement itself
// still loses nothing once the database is back. And the probe is bounded
// however the database fails, a server that stops answering included.
#include <signal.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "common/util/sha256.h"
#include "server/scheduler/bake_scheduler.h"
#include "server/metrics/farm_metrics.h"
#include "server/store/postgres/pg_connection_pool.h"
#include "tests/server/job_store_test_engines.h"

namespace impostor::testing {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Waits (polling, bounded) until `store` knows the database is down.
bool WaitForOutage(const JobStore& store) {
  const auto give_up = Clock::now() + std::chrono::seconds(30);
  while (store.Outage().ok()) {
    if (Clock::now() > give_up) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return true;
}

// Long enough that a view queued behind the reconnect could not pass the
// assertions below by luck.
constexpr int64_t kReconnectWindowMs = 120'000;
constexpr double kAnswerWithinSeconds = 10;

TEST(DatabaseOutage, ReadinessAndViewsAnswerAtOnceWhileASubmitWaitsOutTheOutage) {
  auto pg = PostgresInstance::Start();  // its own: it is stopped below
  ASSERT_TRUE(pg.ok()) << pg.status();
  ASSERT_TRUE((*pg)->CreateDatabase("jobs").ok());
  auto store = PostgresJobStore::Open(
      {.url = (*pg)->Url("jobs"), .pool_size = 2, .reconnect_window_ms = kReconnectWindowMs});
  ASSERT_TRUE(store.ok()) << store.status();
  const auto dir = std::filesystem::temp_directory_path() / ("database_outage_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  auto blobs = BlobStore::Open(dir);
  ASSERT_TRUE(blobs.ok()) << blobs.status();
  BakeScheduler scheduler(store->get(), blobs->get(), SchedulerOptions{});
  ASSERT_TRUE(scheduler.CheckReady().ok());
  FarmMetrics metrics(&scheduler, blobs->get());
  ASSERT_NE(metrics.Scrape().find("impostor_jobs{"), std::string::npos) << "the gauges are there before";

  const std::string mesh = "a mesh submitted during the outage";
  v1::SubmitBakeRequest request;
  request.mutable_mesh()->mutable_entry()->set_path("model.glb");
  request.mutable_mesh()->mutable_entry()->mutable_digest()->set_hash(Sha256Hex(mesh));
  request.mutable_mesh()->mutable_entry()->mutable_digest()->set_size_bytes(static_cast<int64_t>(mesh.size()));
  ASSERT_TRUE((*blobs)->Put({Sha256Hex(mesh), static_cast<int64_t>(mesh.size())}, mesh).ok());

  ASSERT_TRUE((*pg)->Stop().ok());
  absl::StatusOr<v1::SubmitBakeResponse> submitted = absl::UnknownError("not run");
  std::thread submitter([&] { submitted = scheduler.Submit(request, "client"); });
  // The submit now holds the scheduler's lock, reconnecting.
  ASSERT_TRUE(WaitForOutage(**store));

  auto start = Clock::now();
  const absl::Status ready = scheduler.CheckReady();
  EXPECT_LT(SecondsSince(start), kAnswerWithinSeconds);
  EXPECT_EQ(ready.code(), absl::StatusCode::kUnavailable) << ready;
  EXPECT_NE(ready.message().find("job database"), std::string::npos) << ready;

  start = Clock::now();
  auto counts = scheduler.JobCountsByState();
  auto workers = scheduler.Workers();
  auto jobs = scheduler.ListJobs(v1::JOB_STATE_UNSPECIFIED, 10, std::nullopt);
  EXPECT_LT(SecondsSince(start), kAnswerWithinSeconds);
  EXPECT_EQ(counts.status().code(), absl::StatusCode::kUnavailable) << counts.status();
  EXPECT_NE(counts.status().message().find("unreachable for"), std::string::npos) << counts.status();
  EXPECT_EQ(workers.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(jobs.status().code(), absl::StatusCode::kUnavailable);
  // /metrics answers too: not ready, and no job or worker gauge left at
  // its value from before the outage.
  start = Clock::now();
  const std::string scrape = metrics.Scrape();
  EXPECT_LT(SecondsSince(start), kAnswerWithinSeconds);
  EXPECT_NE(scrape.find("\nimpostor_ready 0"), std::string::npos) << scrape;
  EXPECT_EQ(scrape.find("impostor_jobs{"), std::string::npos) << scrape;

  // Back: the waiting submit goes through, and everything answers again.
  ASSERT_TRUE((*pg)->StartAgain().ok());
  submitter.join();
  ASSERT_TRUE(submitted.ok()) << submitted.status();
  EXPECT_TRUE(scheduler.CheckReady().ok());
  EXPECT_TRUE((*store)->Outage().ok());
  auto after = scheduler.JobCountsByState();
  ASSERT_TRUE(after.ok()) << after.status();
  EXPECT_EQ((*after)[v1::JOB_STATE_QUEUED], 1);
  std::filesystem::remove_all(dir);
}

TEST(DatabaseOutage, AProbeGivesUpOnAServerThatStopsAnsweringWithinItsBudget) {
  const std::string url = FreshPostgresDatabase();
  ASSERT_FALSE(url.empty());
  auto pool = PgConnectionPool::Open({.url = url, .size = 1, .reconnect_window_ms = kReconnectWindowMs});
  ASSERT_TRUE(pool.ok()) << pool.status();
  ASSERT_TRUE((*pool)->Probe(2000).ok());
  // The probe keeps its connection: freeze the backend process serving it
  // (the only session of this database whose last statement was SELECT 1).
  auto pid = SharedPostgres()->Query(
      DatabaseName(url), "SELECT pid FROM pg_stat_activity WHERE query = 'SELECT 1' AND pid <> pg_backend_pid()");
  ASSERT_TRUE(pid.ok()) << pid.status();
  const int backend = std::atoi(pid->c_str());
  ASSERT_GT(backend, 0) << *pid;
  ASSERT_EQ(::kill(backend, SIGSTOP), 0);

  const auto start = Clock::now();
  const absl::Status frozen = (*pool)->Probe(500);
  const double took = SecondsSince(start);
  ASSERT_EQ(::kill(backend, SIGCONT), 0);
  EXPECT_LT(took, kAnswerWithinSeconds);
  EXPECT_EQ(frozen.code(), absl::StatusCode::kUnavailable) << frozen;
  EXPECT_NE(frozen.message().find("no answer within 500 ms"), std::string::npos) << frozen;
  EXPECT_EQ((*pool)->Outage().code(), absl::StatusCode::kUnavailable);

  // The next probe starts a new connection and clears the outage.
  EXPECT_TRUE((*pool)->Probe(2000).ok());
  EXPECT_TRUE((*pool)->Outage().ok());
}

// The probe keeps its connection between probes; a database restart kills
// it unseen. The first probe after the restart must still say "up".
TEST(DatabaseOutage, TheFirstProbeAfterARestartFindsTheDatabaseUp) {
  auto pg = PostgresInstance::Start();  // its own: it is restarted below
  ASSERT_TRUE(pg.ok()) << pg.status();
  ASSERT_TRUE((*pg)->CreateDatabase("jobs").ok());
  auto pool = PgConnectionPool::Open({.url = (*pg)->Url("jobs"), .size = 1});
  ASSERT_TRUE(pool.ok()) << pool.status();
  ASSERT_TRUE((*pool)->Probe(2000).ok());
  ASSERT_TRUE((*pg)->Restart().ok());
  const absl::Status after = (*pool)->Probe(2000);
  EXPECT_TRUE(after.ok()) << after;
  EXPECT_TRUE((*pool)->Outage().ok());
}

TEST(DatabaseOutage, TheEmbeddedEngineIsAlwaysReachable) {
  auto store = SqliteEngine::Make();
  ASSERT_TRUE(store.ok()) << store.status();
  EXPECT_TRUE((*store)->Probe(1).ok());
  EXPECT_TRUE((*store)->Outage().ok());
}

}  // namespace
}  // namespace impostor::testing
