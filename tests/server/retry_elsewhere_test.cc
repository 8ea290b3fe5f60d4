// A job that a worker failed retryably for a reason of its own (memory not
// free right now, a full scratch, a device error) is offered to other
// workers first: the worker that failed it skips it for
// SchedulerOptions::retry_elsewhere_ms while other work, or another worker
// that could take it, exists; alone, or once that time has passed, it gets
// the job back, so no job starves. One scheduler logic on both engines:
// BakeScheduler over SQLite and over PostgreSQL, a fake clock, explicit
// leases, no sleeps.
//
// Defect: the failed job went straight back to the queue and the same
// worker's next LeaseJob, milliseconds later, took it again, so one worker
// spent all of its attempts while another sat idle.
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "common/util/sha256.h"
#include "server/scheduler/bake_scheduler.h"
#include "tests/server/job_store_test_engines.h"

namespace impostor::testing {
namespace {

constexpr int64_t kLeaseTimeoutMs = 30'000;
constexpr int64_t kRetryElsewhereMs = 60'000;

template <class Engine>
class RetryElsewhere : public ::testing::Test {
 protected:
  void SetUp() override {
    static int next = 0;
    dir_ = std::filesystem::temp_directory_path() /
           ("retry_elsewhere_" + std::to_string(::getpid()) + "_" + std::to_string(next++));
    std::filesystem::remove_all(dir_);
    auto blobs = BlobStore::Open(dir_);
    ASSERT_TRUE(blobs.ok()) << blobs.status();
    blobs_ = std::move(*blobs);
    auto store = Engine::Make();
    ASSERT_TRUE(store.ok()) << store.status();
    store_ = std::move(*store);
    scheduler_ = std::make_unique<BakeScheduler>(store_.get(), blobs_.get(),
                                                 SchedulerOptions{.lease_timeout_ms = kLeaseTimeoutMs,
                                                                  .max_attempts = 3,
                                                                  // Pauses are another story (lease_loss_test.cc).
                                                                  .worker_failure_limit = 0,
                                                                  .retry_elsewhere_ms = kRetryElsewhereMs,
                                                                  .now_ms = [this] { return now_ms_; }});
  }
  void TearDown() override {
    scheduler_.reset();
    store_.reset();
    blobs_.reset();
    std::filesystem::remove_all(dir_);
  }

  // Submits a bake of a mesh whose bytes are `content`; the job id. The
  // clock moves 1 ms, so submission order is creation order.
  std::string Submit(const std::string& content) {
    v1::Digest d;
    d.set_hash(Sha256Hex(content));
    d.set_size_bytes(static_cast<int64_t>(content.size()));
    EXPECT_TRUE(blobs_->Put({d.hash(), d.size_bytes()}, content).ok());
    v1::SubmitBakeRequest r;
    r.mutable_mesh()->mutable_entry()->set_path("model.glb");
    *r.mutable_mesh()->mutable_entry()->mutable_digest() = d;
    auto submitted = scheduler_->Submit(r, "client");
    EXPECT_TRUE(submitted.ok()) << submitted.status();
    ++now_ms_;
    return submitted.ok() ? submitted->job_id() : "";
  }
  // One LeaseJob that does not wait; empty job_id when nothing was leased.
  v1::LeasedJob Lease(const std::string& worker) {
    v1::LeaseJobRequest r;
    r.set_worker_id(worker);
    auto job = scheduler_->Lease(r, std::chrono::steady_clock::now(), nullptr);
    EXPECT_TRUE(job.ok()) << job.status();
    return job.ok() && job->has_value() ? **job : v1::LeasedJob();
  }
  // What a worker short of free memory sends (worker/bake_memory_check.h).
  void FailForWorkersOwnReason(const v1::LeasedJob& job) {
    v1::FailJobRequest f;
    f.set_job_id(job.job_id());
    f.set_lease_id(job.lease_id());
    f.set_retryable(true);
    f.mutable_error()->set_code(14);  // UNAVAILABLE
    f.mutable_error()->set_message("this worker has 64.0 GB but 100 MB available now: another worker may take it");
    ASSERT_TRUE(scheduler_->Fail(f).ok());
  }
  // A heartbeat: the worker holding `job` is alive and busy.
  void Beat(const v1::LeasedJob& job) {
    v1::ReportProgressRequest p;
    p.set_job_id(job.job_id());
    p.set_lease_id(job.lease_id());
    p.set_progress(0.5f);
    ASSERT_TRUE(scheduler_->ReportProgress(p).ok());
  }
  v1::Job Job(const std::string& id) {
    auto j = scheduler_->GetJob(id);
    EXPECT_TRUE(j.ok()) << j.status();
    return j.ok() ? *j : v1::Job();
  }

  std::filesystem::path dir_;
  // Moved by hand; starts at the real time, as the database's clock reads.
  int64_t now_ms_ = std::chrono::duration_cast<std::chrono::milliseconds>(
                        std::chrono::system_clock::now().time_since_epoch())
                        .count();
  std::unique_ptr<BlobStore> blobs_;
  std::unique_ptr<JobStore> store_;
  std::unique_ptr<BakeScheduler> scheduler_;
};

TYPED_TEST_SUITE(RetryElsewhere, JobStoreEngines, EngineNames);

TYPED_TEST(RetryElsewhere, TheFailingWorkersNextLeaseSkipsTheJobAndAnotherWorkerGetsIt) {
  EXPECT_TRUE(this->Lease("b").job_id().empty());  // b is about: polling, nothing queued yet
  const std::string j = this->Submit("big");
  const v1::LeasedJob first = this->Lease("a");
  ASSERT_EQ(first.job_id(), j);
  this->FailForWorkersOwnReason(first);
  ASSERT_EQ(this->Job(j).state(), v1::JOB_STATE_QUEUED);

  EXPECT_TRUE(this->Lease("a").job_id().empty()) << "worker a took back the job it just failed";
  const v1::LeasedJob second = this->Lease("b");
  EXPECT_EQ(second.job_id(), j);
  EXPECT_EQ(second.attempt(), 2u);
  EXPECT_EQ(this->Job(j).worker_id(), "b");
}

TYPED_TEST(RetryElsewhere, TheFailingWorkerBakesOtherQueuedWorkMeanwhile) {
  EXPECT_TRUE(this->Lease("b").job_id().empty());
  const std::string j = this->Submit("big");
  const std::string k = this->Submit("small, queued behind it");  // same client: not a queue head until j leaves
  const v1::LeasedJob first = this->Lease("a");
  ASSERT_EQ(first.job_id(), j);
  this->FailForWorkersOwnReason(first);

  EXPECT_EQ(this->Lease("a").job_id(), k) << "a should take the next job, not the one it failed";
  EXPECT_EQ(this->Lease("b").job_id(), j);
}

TYPED_TEST(RetryElsewhere, AJobNoOtherWorkerTakesWithinTheBoundGoesBackToItsWorker) {
  const std::string busy_job = this->Submit("long bake");
  const v1::LeasedJob busy = this->Lease("b");  // b is alive but busy all along
  ASSERT_EQ(busy.job_id(), busy_job);
  const std::string j = this->Submit("big");
  const v1::LeasedJob first = this->Lease("a");
  ASSERT_EQ(first.job_id(), j);
  this->FailForWorkersOwnReason(first);

  EXPECT_TRUE(this->Lease("a").job_id().empty()) << "b may finish and take it";
  this->now_ms_ += kRetryElsewhereMs - 1000;
  this->Beat(busy);
  EXPECT_TRUE(this->Lease("a").job_id().empty()) << "still within the bound";
  this->now_ms_ += 2000;
  this->Beat(busy);
  const v1::LeasedJob again = this->Lease("a");
  EXPECT_EQ(again.job_id(), j) << "the bound has passed: the job must not starve";
  EXPECT_EQ(again.attempt(), 2u);
}

TYPED_TEST(RetryElsewhere, ALoneWorkerGetsTheJobBackAtOnce) {
  struct Case {
    const char* name;
    // Workers other than "a" heard from before a fails the job.
    std::vector<std::string> others;
    // Whether the others failed the job too (before a did).
    bool others_failed_it = false;
  };
  const Case cases[] = {
      {"no other worker", {}},
      {"the only other worker failed it too", {"b"}, true},
      {"the other worker went quiet a lease timeout ago", {"gone"}},
  };
  int n = 0;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string j = this->Submit(absl::StrCat("job of case ", n++));
    for (const std::string& other : c.others) {
      const v1::LeasedJob got = this->Lease(other);
      if (c.others_failed_it) {
        ASSERT_EQ(got.job_id(), j);
        this->FailForWorkersOwnReason(got);
      } else {
        ASSERT_EQ(got.job_id(), j);
        v1::ReleaseJobRequest back;
        back.set_job_id(got.job_id());
        back.set_lease_id(got.lease_id());
        back.set_reason("test: hand it on");
        ASSERT_TRUE(this->scheduler_->Release(back).ok());
        this->now_ms_ += kLeaseTimeoutMs + 1;  // and is not heard from again
      }
    }
    const v1::LeasedJob first = this->Lease("a");
    ASSERT_EQ(first.job_id(), j);
    this->FailForWorkersOwnReason(first);
    const v1::LeasedJob again = this->Lease("a");
    EXPECT_EQ(again.job_id(), j);
    ASSERT_TRUE(this->scheduler_->CancelJob(j).ok());
    this->now_ms_ += kRetryElsewhereMs + kLeaseTimeoutMs;  // the next case starts afresh
  }
}

}  // namespace
}  // namespace impostor::testing
