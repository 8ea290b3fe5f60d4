// Lease order: priorities, fairness between clients, shared bakes, and the
// priority column's schema migration. Every lease is an explicit call on an
// in-process scheduler with a fake clock.
#include <sqlite3.h>

#include <climits>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/server/scheduler_fixture.h"

namespace impostor {
namespace {

class PrioritySchedulingTest : public testing_support::SchedulerFixture {
 protected:
  // Submits `count` distinct models for `client` and remembers whose they are.
  void SubmitMany(const std::string& client, int count, int32_t priority) {
    for (int i = 0; i < count; ++i) {
      auto r = Submit(Request(client + " model " + std::to_string(i), priority), client);
      owner_[r.job_id()] = client;
    }
  }
  // Leases one job (completing it at once when `complete`, as a single
  // worker would) and returns its client; "" when nothing was queued.
  std::string LeaseClient(bool complete) {
    v1::LeasedJob job = Lease();
    if (job.job_id().empty()) return "";
    if (complete) EXPECT_TRUE(scheduler_->Complete(Result(job)).ok());
    return owner_[job.job_id()];
  }
  std::map<std::string, std::string> owner_;  // job id -> client
};

TEST_F(PrioritySchedulingTest, HighPriorityJobOvertakesALongLowPriorityBatch) {
  SubmitMany("ci", 20, -50);
  // The farm is busy with the batch when a person asks for one asset.
  EXPECT_EQ(LeaseClient(/*complete=*/true), "ci");
  EXPECT_EQ(LeaseClient(/*complete=*/false), "ci");
  auto artist = Submit(Request("hero prop", 50), "artist");
  owner_[artist.job_id()] = "artist";
  EXPECT_EQ(artist.job().priority(), 50);
  v1::LeasedJob next = Lease();
  EXPECT_EQ(next.job_id(), artist.job_id()) << "the interactive job must start before the batch's remaining 18";
  for (int i = 0; i < 18; ++i) EXPECT_EQ(LeaseClient(true), "ci") << "lease " << i;
  EXPECT_EQ(LeaseClient(true), "") << "everything leased";
}

TEST_F(PrioritySchedulingTest, EqualPriorityClientsAlternateWithOneWorker) {
  SubmitMany("ci", 6, 0);
  SubmitMany("bob", 3, 0);  // submitted after the whole batch
  std::vector<std::string> order;
  for (int i = 0; i < 9; ++i) order.push_back(LeaseClient(/*complete=*/true));
  EXPECT_EQ(order, (std::vector<std::string>{"ci", "bob", "ci", "bob", "ci", "bob", "ci", "ci", "ci"}));
}

TEST_F(PrioritySchedulingTest, EqualPriorityClientsAlternateWithManyWorkers) {
  SubmitMany("ci", 6, 0);
  SubmitMany("bob", 2, 0);
  SubmitMany("eve", 1, 0);
  std::vector<std::string> order;
  // Nothing completes: the client with the fewest running jobs goes next.
  for (int i = 0; i < 9; ++i) order.push_back(LeaseClient(/*complete=*/false));
  EXPECT_EQ(order, (std::vector<std::string>{"ci", "bob", "eve", "ci", "bob", "ci", "ci", "ci", "ci"}));
}

TEST_F(PrioritySchedulingTest, HigherPriorityWinsOverFairness) {
  SubmitMany("ci", 3, 10);
  SubmitMany("bob", 3, 0);
  std::vector<std::string> order;
  for (int i = 0; i < 6; ++i) order.push_back(LeaseClient(true));
  EXPECT_EQ(order, (std::vector<std::string>{"ci", "ci", "ci", "bob", "bob", "bob"}));
}

TEST_F(PrioritySchedulingTest, SharedBakeTakesTheHighestPriorityOfItsRequesters) {
  auto low = Submit(Request("shared model", -50), "ci");
  auto other = Submit(Request("other model", 0), "bob");
  auto urgent = Submit(Request("shared model", 80), "artist");  // follows the ci bake
  EXPECT_EQ(urgent.job().priority(), 80);
  EXPECT_EQ(low.cache_key(), urgent.cache_key());
  v1::LeasedJob first = Lease();
  EXPECT_EQ(first.job_id(), low.job_id()) << "the shared bake runs at 80";
  EXPECT_EQ(Lease().job_id(), other.job_id());
}

TEST_F(PrioritySchedulingTest, SharedBakeDropsBackWhenTheUrgentRequesterCancels) {
  auto low = Submit(Request("shared model", -50), "ci");
  auto other = Submit(Request("other model", 0), "bob");
  auto urgent = Submit(Request("shared model", 80), "artist");
  ASSERT_TRUE(scheduler_->CancelJob(urgent.job_id()).ok());
  EXPECT_EQ(Lease().job_id(), other.job_id()) << "only the -50 requester still wants the shared bake";
  EXPECT_EQ(Lease().job_id(), low.job_id());
}

TEST_F(PrioritySchedulingTest, IdenticalAssetsInOneBatchAreBakedOnce) {
  std::vector<v1::SubmitBakeResponse> batch;
  for (int i = 0; i < 3; ++i) batch.push_back(Submit(Request("same bytes"), "ci"));
  v1::LeasedJob job = Lease();
  ASSERT_FALSE(job.job_id().empty());
  EXPECT_TRUE(Lease().job_id().empty()) << "three identical requests, one bake";
  ASSERT_TRUE(scheduler_->Complete(Result(job)).ok());
  for (const auto& r : batch) {
    auto j = scheduler_->GetJob(r.job_id());
    ASSERT_TRUE(j.ok());
    EXPECT_EQ(j->state(), v1::JOB_STATE_SUCCEEDED) << r.job_id();
  }
  // And a later batch with the same asset never reaches the queue.
  auto again = Submit(Request("same bytes"), "ci");
  EXPECT_TRUE(again.cached());
  EXPECT_TRUE(Lease().job_id().empty());
}

TEST_F(PrioritySchedulingTest, PriorityOutOfRangeIsRefusedNamingTheField) {
  for (int32_t p : {-101, 101, INT32_MAX, INT32_MIN}) {
    auto r = scheduler_->Submit(Request("model", p), "ci");
    ASSERT_FALSE(r.ok()) << p;
    EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument) << p;
    EXPECT_NE(r.status().message().find("priority: " + std::to_string(p) + " is out of range -100..100"),
              std::string::npos)
        << r.status();
  }
  for (int32_t p : {-100, 100}) EXPECT_TRUE(scheduler_->Submit(Request("model", p), "ci").ok()) << p;
}

TEST_F(PrioritySchedulingTest, PrioritySurvivesARestart) {
  SubmitMany("ci", 2, -10);
  auto urgent = Submit(Request("urgent", 40), "artist");
  Reopen();
  auto job = scheduler_->GetJob(urgent.job_id());
  ASSERT_TRUE(job.ok());
  EXPECT_EQ(job->priority(), 40);
  EXPECT_EQ(Lease().job_id(), urgent.job_id());
}

// A database written before the priority column existed opens, keeps its
// jobs (priority 0) and schedules them.
TEST_F(PrioritySchedulingTest, OldDatabaseIsMigrated) {
  scheduler_.reset();
  jobs_.reset();
  const std::filesystem::path file = dir_ / "old.sqlite3";
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
  const char* old_schema = R"sql(
CREATE TABLE jobs (
  job_id TEXT PRIMARY KEY, cache_key TEXT NOT NULL, state INTEGER NOT NULL, created_ms INTEGER NOT NULL,
  lease_id TEXT NOT NULL DEFAULT '', lease_deadline_ms INTEGER NOT NULL DEFAULT 0,
  worker_id TEXT NOT NULL DEFAULT '', job BLOB NOT NULL, request BLOB NOT NULL,
  leader_job_id TEXT NOT NULL DEFAULT '', requester_cancelled INTEGER NOT NULL DEFAULT 0,
  client_id TEXT NOT NULL DEFAULT '');
CREATE TABLE results (cache_key TEXT PRIMARY KEY, manifest BLOB NOT NULL, created_ms INTEGER NOT NULL,
  last_used_ms INTEGER NOT NULL DEFAULT 0, pinned INTEGER NOT NULL DEFAULT 0);
)sql";
  ASSERT_EQ(sqlite3_exec(db, old_schema, nullptr, nullptr, nullptr), SQLITE_OK);
  v1::Job job;
  job.set_job_id("job-old");
  job.set_cache_key(std::string(64, 'a'));
  job.set_state(v1::JOB_STATE_QUEUED);
  v1::SubmitBakeRequest request = Request("old model");
  sqlite3_stmt* st = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db,
                               "INSERT INTO jobs (job_id, cache_key, state, created_ms, job, request) "
                               "VALUES ('job-old', ?1, 1, 5, ?2, ?3)",
                               -1, &st, nullptr),
            SQLITE_OK);
  const std::string job_bytes = job.SerializeAsString(), request_bytes = request.SerializeAsString();
  sqlite3_bind_text(st, 1, job.cache_key().c_str(), -1, SQLITE_TRANSIENT);
  sqlite3_bind_blob(st, 2, job_bytes.data(), static_cast<int>(job_bytes.size()), SQLITE_TRANSIENT);
  sqlite3_bind_blob(st, 3, request_bytes.data(), static_cast<int>(request_bytes.size()), SQLITE_TRANSIENT);
  ASSERT_EQ(sqlite3_step(st), SQLITE_DONE);
  sqlite3_finalize(st);
  sqlite3_close(db);

  auto opened = JobStore::Open(file);
  ASSERT_TRUE(opened.ok()) << opened.status();
  jobs_ = std::move(*opened);
  scheduler_ = std::make_unique<BakeScheduler>(jobs_.get(), blobs_.get(),
                                               SchedulerOptions{.now_ms = [this] { return now_ms_; }});
  auto old = scheduler_->GetJob("job-old");
  ASSERT_TRUE(old.ok()) << old.status();
  EXPECT_EQ(old->priority(), 0);
  auto urgent = Submit(Request("new urgent", 1), "artist");
  EXPECT_EQ(Lease().job_id(), urgent.job_id());
  EXPECT_EQ(Lease().job_id(), "job-old");
  // Opening again is a no-op migration.
  scheduler_.reset();
  jobs_.reset();
  EXPECT_TRUE(JobStore::Open(file).ok());
}

}  // namespace
}  // namespace impostor

namespace impostor {
namespace {

// A measurement, not a check (run with --gtest_also_run_disabled_tests): how
// long one Lease takes with a long queue from several clients.
TEST_F(PrioritySchedulingTest, DISABLED_LeaseTimeWithALongQueue) {
  constexpr int kJobs = 3000;
  for (int i = 0; i < kJobs; ++i) {
    const std::string client = i % 10 == 0 ? "artist" : (i % 3 == 0 ? "ci-a" : "ci-b");
    Submit(Request("model " + std::to_string(i), i % 10 == 0 ? 0 : -50), client);
  }
  const auto start = std::chrono::steady_clock::now();
  constexpr int kLeases = 200;
  for (int i = 0; i < kLeases; ++i) ASSERT_FALSE(Lease().job_id().empty());
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  std::printf("lease with %d queued: %.2f ms each (including the SQLite write)\n", kJobs, ms / kLeases);
}

}  // namespace
}  // namespace impostor
