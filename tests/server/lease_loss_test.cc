// How leases end other than by a result: handed back by a draining worker
// (ReleaseJob), lost to a dead or hung worker (expiry, or the supervisor
// seeing the process die), and the pause of a worker that keeps failing
// different jobs. Fake clock, explicit leases, no sleeps.
#include <functional>
#include <string>

#include <gtest/gtest.h>

#include "common/error_reason.h"
#include "server/store/database_full.h"
#include "server/blobs/disk_full.h"
#include "tests/server/scheduler_fixture.h"

namespace impostor {
namespace {

class LeaseLossTest : public testing_support::SchedulerFixture {
 protected:
  v1::ReleaseJobRequest ReleaseOf(const v1::LeasedJob& job, const std::string& reason = "worker draining") {
    v1::ReleaseJobRequest r;
    r.set_job_id(job.job_id());
    r.set_lease_id(job.lease_id());
    r.set_reason(reason);
    return r;
  }
  v1::FailJobRequest RetryableFailure(const v1::LeasedJob& job, int code = 13,
                                      const std::string& message = "device lost", const std::string& reason = "") {
    v1::FailJobRequest f;
    f.set_job_id(job.job_id());
    f.set_lease_id(job.lease_id());
    f.set_retryable(true);
    f.mutable_error()->set_code(code);
    f.mutable_error()->set_message(message);
    f.mutable_error()->set_reason(reason);
    return f;
  }
  void ReportStage(const v1::LeasedJob& job, const std::string& stage) {
    v1::ReportProgressRequest p;
    p.set_job_id(job.job_id());
    p.set_lease_id(job.lease_id());
    p.set_progress(0.5f);
    p.set_stage(stage);
    ASSERT_TRUE(scheduler_->ReportProgress(p).ok());
  }
  // Submits a job, leases it to `worker` (nothing else is queued), fails it
  // and cancels it so it leaves the queue.
  void FailNewJob(const std::string& worker, const std::string& content, bool retryable = true) {
    const std::string id = Submit(Request(content), "c").job_id();
    const v1::LeasedJob job = Lease(worker);
    ASSERT_EQ(job.job_id(), id) << "the queue was not empty";
    v1::FailJobRequest f = RetryableFailure(job);
    f.set_retryable(retryable);
    ASSERT_TRUE(scheduler_->Fail(f).ok());
    ASSERT_TRUE(scheduler_->CancelJob(id).ok());
  }
  // Lets every current lease run out and expires it.
  void ExpireAll() {
    now_ms_ += scheduler_->options().lease_timeout_ms + 1;
    ASSERT_TRUE(scheduler_->ExpireLeases().ok());
  }
  v1::Job Job(const std::string& id) {
    auto j = scheduler_->GetJob(id);
    EXPECT_TRUE(j.ok()) << j.status();
    return j.ok() ? *j : v1::Job();
  }
};

TEST_F(LeaseLossTest, AReleasedJobIsQueuedAtOnceWithoutCountingTheAttempt) {
  const std::string id = Submit(Request("tree"), "c").job_id();
  const v1::LeasedJob first = Lease("draining-worker");
  ASSERT_EQ(first.attempt(), 1u);
  ASSERT_TRUE(scheduler_->Release(ReleaseOf(first)).ok());
  EXPECT_EQ(Job(id).state(), v1::JOB_STATE_QUEUED);
  EXPECT_EQ(Job(id).attempts(), 0u);
  // No clock advance: the next worker gets it now, not after the timeout.
  const v1::LeasedJob second = Lease("other-worker");
  EXPECT_EQ(second.job_id(), id);
  EXPECT_EQ(second.attempt(), 1u) << "the handed-back lease does not count";
  EXPECT_EQ(Job(id).worker_id(), "other-worker");
  ASSERT_TRUE(scheduler_->Complete(Result(second)).ok());
  EXPECT_EQ(Job(id).state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(Job(id).attempts(), 1u);
}

TEST_F(LeaseLossTest, ReleaseIsFencedByTheLease) {
  Submit(Request("tree"), "c");
  const v1::LeasedJob job = Lease();
  struct Case {
    const char* name;
    v1::ReleaseJobRequest request;
    absl::StatusCode code;
    const char* says;
  };
  v1::ReleaseJobRequest wrong_lease = ReleaseOf(job);
  wrong_lease.set_lease_id("lease-not-this-one");
  v1::ReleaseJobRequest no_lease = ReleaseOf(job);
  no_lease.clear_lease_id();
  v1::ReleaseJobRequest no_job = ReleaseOf(job);
  no_job.set_job_id("job-unknown");
  v1::ReleaseJobRequest long_reason = ReleaseOf(job, std::string(1025, 'r'));
  const Case cases[] = {
      {"wrong lease", wrong_lease, absl::StatusCode::kFailedPrecondition, "lease_id: "},
      {"empty lease", no_lease, absl::StatusCode::kInvalidArgument, "lease_id: required"},
      {"unknown job", no_job, absl::StatusCode::kNotFound, "job_id: "},
      {"long reason", long_reason, absl::StatusCode::kInvalidArgument, "reason: 1025 bytes is over the limit of 1024"},
  };
  for (const Case& c : cases) {
    const absl::Status s = scheduler_->Release(c.request);
    EXPECT_EQ(s.code(), c.code) << c.name << ": " << s;
    EXPECT_NE(s.message().find(c.says), std::string::npos) << c.name << ": " << s;
  }
  EXPECT_EQ(Job(job.job_id()).state(), v1::JOB_STATE_RUNNING) << "refused releases change nothing";
  ASSERT_TRUE(scheduler_->Release(ReleaseOf(job)).ok());
  // The old lease is dead for every later call.
  EXPECT_EQ(scheduler_->Release(ReleaseOf(job)).code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(scheduler_->Complete(Result(job)).code(), absl::StatusCode::kFailedPrecondition);
}

TEST_F(LeaseLossTest, ReleasingACancelledBakeKeepsItCancelled) {
  const std::string id = Submit(Request("tree"), "c").job_id();
  const v1::LeasedJob job = Lease();
  ASSERT_TRUE(scheduler_->CancelJob(id).ok());
  ASSERT_TRUE(scheduler_->Release(ReleaseOf(job)).ok());
  EXPECT_EQ(Job(id).state(), v1::JOB_STATE_CANCELLED);
  EXPECT_TRUE(Lease("w2").job_id().empty()) << "a cancelled bake is not queued again";
}

TEST_F(LeaseLossTest, AJobWhoseWorkersKeepDyingSaysSo) {
  const std::string id = Submit(Request("poison"), "c").job_id();
  for (int attempt = 1; attempt <= 3; ++attempt) {
    const v1::LeasedJob job = Lease("w" + std::to_string(attempt));
    ASSERT_EQ(job.job_id(), id) << "attempt " << attempt;
    ReportStage(job, "render");
    ExpireAll();
  }
  const v1::Job done = Job(id);
  EXPECT_EQ(done.state(), v1::JOB_STATE_FAILED);
  EXPECT_EQ(done.attempts(), 3u);
  EXPECT_EQ(done.error().message(),
            "lease expired 3 times: the worker died or hung while baking it (last: worker w3 at stage render)");
  EXPECT_EQ(done.error().code(), static_cast<int>(absl::StatusCode::kInternal));
}

TEST_F(LeaseLossTest, AWorkerDeathSeenByTheSupervisorEndsTheLeaseAtOnce) {
  const std::string id = Submit(Request("poison"), "c").job_id();
  for (int attempt = 1; attempt <= 3; ++attempt) {
    const std::string worker = "local-0-" + std::to_string(100 + attempt);
    const v1::LeasedJob job = Lease(worker);
    ASSERT_EQ(job.job_id(), id) << "attempt " << attempt << ": leased again without waiting for the timeout";
    ReportStage(job, "load");
    ASSERT_TRUE(scheduler_->WorkerDied(worker, "killed by signal 11 (SIGSEGV)").ok());
  }
  const v1::Job done = Job(id);
  EXPECT_EQ(done.state(), v1::JOB_STATE_FAILED);
  EXPECT_EQ(done.error().message(),
            "lease expired 3 times: the worker died or hung while baking it (last: worker local-0-103 at stage load, "
            "the process was killed by signal 11 (SIGSEGV))");
}

TEST_F(LeaseLossTest, ADeadWorkersOtherJobsAreUntouched) {
  Submit(Request("a"), "c");
  Submit(Request("b"), "c");
  const v1::LeasedJob dead = Lease("w-dead");
  const v1::LeasedJob alive = Lease("w-alive");
  ASSERT_TRUE(scheduler_->WorkerDied("w-dead", "killed by signal 9 (SIGKILL)").ok());
  EXPECT_EQ(Job(dead.job_id()).state(), v1::JOB_STATE_QUEUED);
  EXPECT_EQ(Job(alive.job_id()).state(), v1::JOB_STATE_RUNNING);
  EXPECT_TRUE(scheduler_->Complete(Result(alive)).ok());
  ASSERT_TRUE(scheduler_->WorkerDied("w-unknown", "exit 1").ok()) << "a worker with no job is no error";
}

TEST_F(LeaseLossTest, MixedFailuresNameTheLastOne) {
  const std::string id = Submit(Request("flaky"), "c").job_id();
  ASSERT_TRUE(scheduler_->Fail(RetryableFailure(Lease("w1"))).ok());
  Lease("w2");
  ExpireAll();
  ReportStage(Lease("w3"), "encode");
  ExpireAll();
  const v1::Job done = Job(id);
  EXPECT_EQ(done.state(), v1::JOB_STATE_FAILED);
  EXPECT_EQ(done.error().message(),
            "failed after 3 attempts; last error: lease expired: worker w3 died or hung at stage encode");
}

TEST_F(LeaseLossTest, AWorkerThatFailsThreeDifferentJobsIsPaused) {
  FailNewJob("bad-gpu", "a");
  FailNewJob("bad-gpu", "b");
  EXPECT_FALSE(scheduler_->WorkerPaused("bad-gpu")) << "two failures are not yet a pattern";
  FailNewJob("bad-gpu", "c");
  EXPECT_TRUE(scheduler_->WorkerPaused("bad-gpu"));
  Submit(Request("d"), "c");
  EXPECT_TRUE(Lease("bad-gpu").job_id().empty()) << "a paused worker gets nothing while jobs are queued";
  EXPECT_FALSE(Lease("good-gpu").job_id().empty()) << "other workers still lease";
  now_ms_ += scheduler_->options().worker_pause_ms + 1;
  EXPECT_FALSE(scheduler_->WorkerPaused("bad-gpu"));
  Submit(Request("e"), "c");
  EXPECT_FALSE(Lease("bad-gpu").job_id().empty()) << "the pause ends";
}

TEST_F(LeaseLossTest, LeaseExpiriesCountTowardsThePause) {
  for (const char* content : {"a", "b", "c"}) {
    const std::string id = Submit(Request(content), "c").job_id();
    ASSERT_EQ(Lease("hangs").job_id(), id);
    ExpireAll();
    ASSERT_TRUE(scheduler_->CancelJob(id).ok());
  }
  EXPECT_TRUE(scheduler_->WorkerPaused("hangs"));
}

TEST_F(LeaseLossTest, NoLeaseExpiresUntilOneLeaseTimeoutAfterTheDatabaseLastRefusedAWriteForSpace) {
  const std::string id = Submit(Request("waits"), "c").job_id();
  ASSERT_EQ(Lease("w").job_id(), id);
  // The database refuses writes for a full disk (SqliteError and
  // PgStatementError count each refusal): the worker's heartbeats and its
  // finished result cannot be recorded, so its deadline passing says nothing.
  const int64_t timeout = scheduler_->options().lease_timeout_ms;
  for (int sweep = 0; sweep < 4; ++sweep) {
    DatabaseFullRefusals().fetch_add(1);
    now_ms_ += timeout / 2;
    ASSERT_TRUE(scheduler_->ExpireLeases().ok());
    ASSERT_EQ(Job(id).state(), v1::JOB_STATE_RUNNING) << "expired at sweep " << sweep << " while the disk was full";
  }
  // Space is back (no more refusals): one lease timeout for the worker to
  // get through, then the dead worker's lease goes as always.
  now_ms_ += timeout - 1;
  ASSERT_TRUE(scheduler_->ExpireLeases().ok());
  EXPECT_EQ(Job(id).state(), v1::JOB_STATE_RUNNING);
  now_ms_ += 2;
  ASSERT_TRUE(scheduler_->ExpireLeases().ok());
  EXPECT_EQ(Job(id).state(), v1::JOB_STATE_QUEUED);
}

TEST_F(LeaseLossTest, AFailureRelayingTheServersFullStorageCostsNoAttempt) {
  const std::string id = Submit(Request("patient"), "c").job_id();
  // More relayed refusals than max_attempts: the job is never failed for them.
  for (int round = 0; round < 5; ++round) {
    const v1::LeasedJob job = Lease("w");
    ASSERT_EQ(job.job_id(), id) << "round " << round;
    ASSERT_TRUE(scheduler_
                    ->Fail(RetryableFailure(job, 14, "the server's blob store stayed full for 300 s",
                                            round % 2 == 0 ? error_reason::kStoreFull : error_reason::kDatabaseFull))
                    .ok());
    const v1::Job after = Job(id);
    ASSERT_EQ(after.state(), v1::JOB_STATE_QUEUED) << "round " << round << ": " << after.DebugString();
    EXPECT_EQ(after.attempts(), 0u);
  }
  EXPECT_FALSE(scheduler_->WorkerPaused("w"));
  // Another retryable failure still counts.
  ASSERT_TRUE(scheduler_->Fail(RetryableFailure(Lease("w"))).ok());
  EXPECT_EQ(Job(id).attempts(), 1u);
  EXPECT_EQ(Job(id).attempt_history_size(), 6);
}

TEST_F(LeaseLossTest, WhatDoesNotPauseAWorker) {
  struct Case {
    const char* name;
    std::function<void(const std::string& worker)> run;
  };
  const Case cases[] = {
      {"the same job three times",
       [&](const std::string& w) {
         Submit(Request("same " + w), "c");
         for (int i = 0; i < 3; ++i) ASSERT_TRUE(scheduler_->Fail(RetryableFailure(Lease(w))).ok());
       }},
      {"a success between failures",
       [&](const std::string& w) {
         FailNewJob(w, w + "1");
         FailNewJob(w, w + "2");
         Submit(Request(w + "3"), "c");
         ASSERT_TRUE(scheduler_->Complete(Result(Lease(w))).ok());
         FailNewJob(w, w + "4");
       }},
      {"bad input (not retryable)",
       [&](const std::string& w) {
         for (int i = 0; i < 3; ++i) FailNewJob(w, w + std::to_string(i), /*retryable=*/false);
       }},
      {"the server's blob store full past the worker's outage budget",
       [&](const std::string& w) {
         // What a worker sends when its result upload met STORE_FULL for
         // longer than its --max-outage-seconds (worker/worker_loop.cc): the
         // server's own refusal, relayed with its reason word. The store's
         // fault, not the worker's.
         const std::string refusal(
             DiskFullError("write", dir_ / "blobs" / "tmp" / "upload-1", "No space left on device").message());
         for (int i = 0; i < 3; ++i) {
           const std::string id = Submit(Request(w + std::to_string(i)), "c").job_id();
           const v1::LeasedJob job = Lease(w);
           ASSERT_EQ(job.job_id(), id);
           ASSERT_TRUE(scheduler_
                           ->Fail(RetryableFailure(job, 14,
                                                   "the server's blob store stayed full for 300 s "
                                                   "(--max-outage-seconds 300 or the drain deadline): " +
                                                       refusal,
                                                   error_reason::kStoreFull))
                           .ok());
           ASSERT_TRUE(scheduler_->CancelJob(id).ok());
         }
       }},
      {"releases",
       [&](const std::string& w) {
         for (int i = 0; i < 3; ++i) {
           const std::string id = Submit(Request(w + std::to_string(i)), "c").job_id();
           ASSERT_TRUE(scheduler_->Release(ReleaseOf(Lease(w))).ok());
           ASSERT_TRUE(scheduler_->CancelJob(id).ok());
         }
       }},
  };
  int n = 0;
  for (const Case& c : cases) {
    const std::string worker = "w" + std::to_string(n++);
    c.run(worker);
    EXPECT_FALSE(scheduler_->WorkerPaused(worker)) << c.name;
    EXPECT_TRUE(Lease("probe").job_id().empty()) << c.name << " left a job queued";
  }
}

TEST_F(LeaseLossTest, LeaseAnswersUnavailableOnceTheServerStops) {
  Submit(Request("tree"), "c");
  scheduler_->Shutdown();
  v1::LeaseJobRequest r;
  r.set_worker_id("w1");
  auto job = scheduler_->Lease(r, std::chrono::steady_clock::now() + std::chrono::seconds(60), nullptr);
  EXPECT_EQ(job.status().code(), absl::StatusCode::kUnavailable) << job.status();
}

}  // namespace
}  // namespace impostor
