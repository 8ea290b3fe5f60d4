// Issue 18, the serving side: cache hits write nothing to the job database
// (no row, no commit: nothing that needs a sync), their job ids still answer
// GetJob (also after a restart) while the result exists, result use times
// are batched in memory and written at flush and on a clean shutdown, and
// finished job records older than the retention period are swept.
#include <sqlite3.h>

#include <numeric>
#include <string>

#include <gtest/gtest.h>

#include "tests/server/scheduler_fixture.h"

namespace impostor {
namespace {

constexpr int64_t kDayMs = 24 * 3600'000;

class ServingSpeedTest : public testing_support::SchedulerFixture {
 protected:
  // Bakes `content` once (submit, lease, complete); returns the request.
  v1::SubmitBakeRequest Baked(const std::string& content) {
    v1::SubmitBakeRequest request = Request(content);
    Submit(request, "ci-1");
    EXPECT_TRUE(scheduler_->Complete(Result(Lease())).ok());
    return request;
  }

  int64_t JobRows() {
    auto counts = jobs_->CountByState();
    EXPECT_TRUE(counts.ok()) << counts.status();
    int64_t n = 0;
    for (const auto& [state, count] : *counts) n += count;
    return n;
  }

  // PRAGMA data_version as a second connection sees it: it changes when any
  // other connection commits to the database.
  struct Watcher {
    explicit Watcher(const std::filesystem::path& file) {
      EXPECT_EQ(sqlite3_open_v2(file.c_str(), &db, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
    }
    ~Watcher() { sqlite3_close(db); }
    int64_t DataVersion() const {
      sqlite3_stmt* st = nullptr;
      EXPECT_EQ(sqlite3_prepare_v2(db, "PRAGMA data_version", -1, &st, nullptr), SQLITE_OK);
      EXPECT_EQ(sqlite3_step(st), SQLITE_ROW);
      const int64_t v = sqlite3_column_int64(st, 0);
      sqlite3_finalize(st);
      return v;
    }
    sqlite3* db = nullptr;
  };
};

TEST_F(ServingSpeedTest, CacheHitsCommitNothingToTheJobDatabase) {
  const v1::SubmitBakeRequest request = Baked("tree");
  const std::string key = Submit(request, "ci-1").cache_key();
  ASSERT_TRUE(scheduler_->FlushResultTouches().ok());
  const int64_t rows = JobRows();
  Watcher watcher(dir_ / "jobs.sqlite3");
  const int64_t version = watcher.DataVersion();
  for (int i = 0; i < 20; ++i) {
    v1::SubmitBakeRequest r = request;
    r.set_request_id("hit-" + std::to_string(i));
    const v1::SubmitBakeResponse hit = Submit(r, "ci-1");
    ASSERT_TRUE(hit.cached());
    EXPECT_EQ(hit.job().state(), v1::JOB_STATE_SUCCEEDED);
    EXPECT_TRUE(hit.job().has_result());
    auto lookup = scheduler_->Lookup(request);
    ASSERT_TRUE(lookup.ok()) << lookup.status();
    EXPECT_TRUE(lookup->found());
    ASSERT_TRUE(scheduler_->GetResult(key).ok());
  }
  EXPECT_EQ(JobRows(), rows) << "a cache hit must not insert a job row";
  EXPECT_EQ(watcher.DataVersion(), version) << "60 cache hits committed something (a sync each)";
  // The use times are written in one commit when flushed.
  auto flushed = scheduler_->FlushResultTouches();
  ASSERT_TRUE(flushed.ok()) << flushed.status();
  EXPECT_EQ(*flushed, 1);
  EXPECT_NE(watcher.DataVersion(), version);
  EXPECT_EQ(*scheduler_->FlushResultTouches(), 0) << "nothing left to write";
}

TEST_F(ServingSpeedTest, AHitJobIdAnswersGetJobAlsoAfterARestart) {
  const v1::SubmitBakeRequest request = Baked("tree");
  const v1::SubmitBakeResponse hit = Submit(request, "ci-1");
  ASSERT_TRUE(hit.cached());
  Reopen();
  auto job = scheduler_->GetJob(hit.job_id());
  ASSERT_TRUE(job.ok()) << job.status();
  EXPECT_EQ(job->job_id(), hit.job_id());
  EXPECT_EQ(job->state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(job->stage(), "cached");
  EXPECT_TRUE(job->cached());
  EXPECT_EQ(job->cache_key(), hit.cache_key());
  EXPECT_EQ(job->result().cache_key(), hit.cache_key());
  EXPECT_EQ(job->result().maps(0).file(), "albedo_alpha.png");
  // Cancelling a finished hit changes nothing.
  auto cancelled = scheduler_->CancelJob(hit.job_id());
  ASSERT_TRUE(cancelled.ok()) << cancelled.status();
  EXPECT_EQ(cancelled->state(), v1::JOB_STATE_SUCCEEDED);
}

TEST_F(ServingSpeedTest, AHitJobIdNamesItsOwnerForAccessChecks) {
  const v1::SubmitBakeRequest request = Baked("tree");
  auto hit = scheduler_->Submit(request, "alice/ci", "alice");
  ASSERT_TRUE(hit.ok()) << hit.status();
  ASSERT_TRUE(hit->cached());
  auto owner = scheduler_->JobOwner(hit->job_id());
  ASSERT_TRUE(owner.ok()) << owner.status();
  EXPECT_EQ(*owner, "alice");
  auto anonymous = scheduler_->Submit(request, "ci-2");
  ASSERT_TRUE(anonymous.ok());
  EXPECT_EQ(*scheduler_->JobOwner(anonymous->job_id()), "");
}

TEST_F(ServingSpeedTest, ARetriedHitGetsTheSameIdAndAnotherRequestIdAnother) {
  v1::SubmitBakeRequest request = Baked("tree");
  request.set_request_id("one");
  const std::string first = Submit(request, "ci-1").job_id();
  EXPECT_EQ(Submit(request, "ci-1").job_id(), first);
  EXPECT_NE(Submit(request, "ci-2").job_id(), first) << "request ids are per client";
  request.set_request_id("two");
  EXPECT_NE(Submit(request, "ci-1").job_id(), first);
  request.clear_request_id();
  EXPECT_NE(Submit(request, "ci-1").job_id(), Submit(request, "ci-1").job_id()) << "no request id: a fresh id each";
}

TEST_F(ServingSpeedTest, MalformedOrForgottenHitIdsAreNotFound) {
  const v1::SubmitBakeRequest request = Baked("tree");
  const std::string id = Submit(request, "ci-1").job_id();
  ASSERT_EQ(id.substr(0, 4), "hit-");
  const std::string unknown_key(64, 'a');
  for (const std::string& bad : {
           id.substr(0, id.size() - 1),                                  // tag too short
           id + "-",                                                     // empty owner
           id + "-6",                                                    // odd owner hex
           id + "-zz",                                                   // owner not hex
           "hit-" + std::string(64, 'G') + id.substr(68),                // key not hex
           "hit-" + unknown_key + id.substr(68),                         // nothing baked under the key
           std::string("hit-"),
       }) {
    EXPECT_EQ(scheduler_->GetJob(bad).status().code(), absl::StatusCode::kNotFound) << bad;
    EXPECT_EQ(scheduler_->JobOwner(bad).status().code(), absl::StatusCode::kNotFound) << bad;
  }
  // A hit lives as long as its result.
  ASSERT_TRUE(jobs_->DeleteResult(Submit(request, "ci-1").cache_key()).ok());
  EXPECT_EQ(scheduler_->GetJob(id).status().code(), absl::StatusCode::kNotFound);
}

TEST_F(ServingSpeedTest, AGatedHitStillGetsARow) {
  v1::SubmitBakeRequest request = Baked("tree");
  const int64_t rows = JobRows();
  request.mutable_gate()->set_min_iou(0.99f);  // the result has 0.97: fails
  const v1::SubmitBakeResponse hit = Submit(request, "ci-1");
  ASSERT_TRUE(hit.cached());
  EXPECT_EQ(hit.job().state(), v1::JOB_STATE_FAILED);
  EXPECT_EQ(JobRows(), rows + 1);
  auto job = scheduler_->GetJob(hit.job_id());
  ASSERT_TRUE(job.ok()) << job.status();
  EXPECT_EQ(job->state(), v1::JOB_STATE_FAILED) << "the gate's verdict is kept";
}

TEST_F(ServingSpeedTest, UseTimesSurviveACleanShutdownAndShowBeforeTheFlush) {
  const v1::SubmitBakeRequest request = Baked("tree");
  const std::string key = Submit(request, "ci-1").cache_key();
  ASSERT_TRUE(scheduler_->FlushResultTouches().ok());
  now_ms_ += 5 * kDayMs;
  const int64_t used_at = now_ms_;
  ASSERT_TRUE(scheduler_->GetResult(key).ok());
  auto stored = jobs_->GetStoredResult(key);
  ASSERT_TRUE(stored.ok() && stored->has_value());
  EXPECT_LT((*stored)->last_used_ms, used_at) << "not written yet: in memory until the flush";
  auto peek = scheduler_->PeekResult(key);
  ASSERT_TRUE(peek.ok()) << peek.status();
  EXPECT_EQ(peek->last_used_ms, used_at) << "the dashboard sees the use before it is written";
  auto listed = scheduler_->ListResults(10, std::nullopt);
  ASSERT_TRUE(listed.ok() && listed->size() == 1);
  EXPECT_EQ(listed->front().last_used_ms, used_at);
  Reopen();  // destroys the scheduler: a clean shutdown
  stored = jobs_->GetStoredResult(key);
  ASSERT_TRUE(stored.ok() && stored->has_value());
  EXPECT_EQ((*stored)->last_used_ms, used_at);
}

TEST_F(ServingSpeedTest, RetentionDeletesOnlyFinishedJobsOlderThanThePeriod) {
  // Old: one finished, one cancelled while queued, one still running, one
  // still queued (all created at day 0).
  const std::string old_done = Submit(Request("old-done"), "ci-1").job_id();
  ASSERT_TRUE(scheduler_->Complete(Result(Lease())).ok());
  const std::string old_cancelled = Submit(Request("old-cancelled"), "ci-1").job_id();
  ASSERT_TRUE(scheduler_->CancelJob(old_cancelled).ok());
  const std::string old_running = Submit(Request("old-running"), "ci-1").job_id();
  const v1::LeasedJob running = Lease();
  ASSERT_EQ(running.job_id(), old_running);
  const std::string old_queued = Submit(Request("old-queued"), "ci-1").job_id();
  now_ms_ += 6 * kDayMs;
  // Young: finished at day 6.
  const std::string young_done = Submit(Request("young-done"), "ci-2").job_id();
  const v1::LeasedJob young = Lease();  // ci-2 runs nothing yet: served first
  ASSERT_EQ(young.job_id(), young_done);
  ASSERT_TRUE(scheduler_->Complete(Result(young)).ok());
  now_ms_ += 2 * kDayMs;  // day 8: the day-0 jobs are past 7 days

  {
    SchedulerOptions keep;
    keep.job_retention_ms = 0;
    keep.now_ms = [this] { return now_ms_; };
    BakeScheduler keeping(jobs_.get(), blobs_.get(), keep);
    EXPECT_EQ(*keeping.SweepFinishedJobs(), 0) << "retention 0 keeps every job";
  }
  auto swept = scheduler_->SweepFinishedJobs();
  ASSERT_TRUE(swept.ok()) << swept.status();
  EXPECT_EQ(*swept, 2);
  auto exists = [&](const std::string& id) {
    auto r = jobs_->Get(id);
    EXPECT_TRUE(r.ok()) << r.status();
    return r.ok() && r->has_value();
  };
  EXPECT_FALSE(exists(old_done));
  EXPECT_FALSE(exists(old_cancelled));
  EXPECT_TRUE(exists(old_running)) << "a running job is never swept, whatever its age";
  EXPECT_TRUE(exists(old_queued)) << "a queued job is never swept, whatever its age";
  EXPECT_TRUE(exists(young_done));
  EXPECT_EQ(*scheduler_->SweepFinishedJobs(), 0);
  // The result outlives the job records that made it.
  EXPECT_TRUE(scheduler_->Lookup(Request("old-done"))->found());
}

TEST_F(ServingSpeedTest, RetentionSweepsInBatchesUntilDone) {
  for (int i = 0; i < 1203; ++i) {
    JobRecord r;
    r.job.set_job_id("job-old-" + std::to_string(i));
    r.job.set_cache_key(std::string(64, 'b'));
    r.job.set_state(v1::JOB_STATE_FAILED);
    r.job.set_created_ms(now_ms_);
    ASSERT_TRUE(jobs_->Insert(r).ok());
  }
  now_ms_ += 8 * kDayMs;
  EXPECT_EQ(*scheduler_->SweepFinishedJobs(), 1203);
  EXPECT_EQ(JobRows(), 0);
}

}  // namespace
}  // namespace impostor
