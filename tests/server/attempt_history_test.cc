// Job.attempt_history (issue 16): one entry per lease with the worker, its
// device, the lease's start and end and how it ended, kept bounded.
#include "server/store/attempt_history.h"

#include <gtest/gtest.h>

#include "tests/server/scheduler_fixture.h"

namespace impostor {
namespace {

class AttemptHistoryTest : public testing_support::SchedulerFixture {
 protected:
  v1::Job Job(const std::string& id) {
    auto j = scheduler_->GetJob(id);
    EXPECT_TRUE(j.ok()) << j.status();
    return j.ok() ? *j : v1::Job();
  }
};

TEST_F(AttemptHistoryTest, DeadWorkerThenLiveWorkerShowsTwoAttempts) {
  const std::string id = Submit(Request("mesh"), "artist").job_id();
  const int64_t first_lease_ms = now_ms_;
  const v1::LeasedJob first = Lease("dead-worker", "gpu-a");
  ASSERT_EQ(first.job_id(), id);
  EXPECT_EQ(Job(id).attempt_history_size(), 1);
  EXPECT_EQ(Job(id).attempt_history(0).outcome(), v1::JobAttempt::OUTCOME_RUNNING);
  now_ms_ += 31'000;
  const int64_t expired_ms = now_ms_;
  ASSERT_TRUE(scheduler_->ExpireLeases().ok());
  now_ms_ += 5;
  const v1::LeasedJob second = Lease("live-worker", "gpu-b");
  now_ms_ += 100;
  ASSERT_TRUE(scheduler_->Complete(Result(second)).ok());

  const v1::Job job = Job(id);
  ASSERT_EQ(job.state(), v1::JOB_STATE_SUCCEEDED);
  ASSERT_EQ(job.attempt_history_size(), 2);
  const v1::JobAttempt& a = job.attempt_history(0);
  EXPECT_EQ(a.attempt(), 1u);
  EXPECT_EQ(a.worker_id(), "dead-worker");
  EXPECT_EQ(a.device(), "gpu-a");
  EXPECT_EQ(a.leased_ms(), first_lease_ms);
  EXPECT_EQ(a.ended_ms(), expired_ms);
  EXPECT_EQ(a.outcome(), v1::JobAttempt::OUTCOME_LEASE_EXPIRED);
  EXPECT_NE(a.message().find("lease timeout"), std::string::npos) << a.message();
  const v1::JobAttempt& b = job.attempt_history(1);
  EXPECT_EQ(b.attempt(), 2u);
  EXPECT_EQ(b.worker_id(), "live-worker");
  EXPECT_EQ(b.device(), "gpu-b");
  EXPECT_EQ(b.leased_ms(), expired_ms + 5);
  EXPECT_EQ(b.ended_ms(), expired_ms + 105);
  EXPECT_EQ(b.outcome(), v1::JobAttempt::OUTCOME_SUCCEEDED);
  EXPECT_EQ(job.attempt_history_dropped(), 0u);

  // Stored with the job: a restarted server still shows it.
  Reopen();
  EXPECT_EQ(Job(id).attempt_history_size(), 2);
  EXPECT_EQ(Job(id).attempt_history(1).worker_id(), "live-worker");
}

TEST_F(AttemptHistoryTest, EveryWayALeaseEndsIsRecorded) {
  const std::string id = Submit(Request("mesh"), "artist").job_id();
  // failed (retryable, so queued again)
  const v1::LeasedJob a = Lease("w-fail", "d");
  v1::FailJobRequest f;
  f.set_job_id(a.job_id());
  f.set_lease_id(a.lease_id());
  f.set_retryable(true);
  f.mutable_error()->set_code(14);
  f.mutable_error()->set_message("vkQueueSubmit: VK_ERROR_DEVICE_LOST");
  ASSERT_TRUE(scheduler_->Fail(f).ok());
  // released (not counted)
  const v1::LeasedJob b = Lease("w-drain", "d");
  v1::ReleaseJobRequest r;
  r.set_job_id(b.job_id());
  r.set_lease_id(b.lease_id());
  r.set_reason("worker draining (SIGTERM)");
  ASSERT_TRUE(scheduler_->Release(r).ok());
  // the process died
  Lease("w-crash", "d");
  ASSERT_TRUE(scheduler_->WorkerDied("w-crash", "killed by signal 11 (SIGSEGV)").ok());
  // cancelled while running
  Lease("w-cancel", "d");
  ASSERT_TRUE(scheduler_->CancelJob(id).ok());

  const v1::Job job = Job(id);
  ASSERT_EQ(job.attempt_history_size(), 4);
  struct Want {
    const char* worker;
    uint32_t attempt;
    v1::JobAttempt::Outcome outcome;
    const char* message_part;
  } const want[] = {
      {"w-fail", 1, v1::JobAttempt::OUTCOME_FAILED, "VK_ERROR_DEVICE_LOST"},
      {"w-drain", 2, v1::JobAttempt::OUTCOME_RELEASED, "draining"},
      {"w-crash", 2, v1::JobAttempt::OUTCOME_LEASE_EXPIRED, "SIGSEGV"},
      {"w-cancel", 3, v1::JobAttempt::OUTCOME_CANCELLED, "CancelJob"},
  };
  for (int i = 0; i < 4; ++i) {
    SCOPED_TRACE(want[i].worker);
    const v1::JobAttempt& got = job.attempt_history(i);
    EXPECT_EQ(got.worker_id(), want[i].worker);
    EXPECT_EQ(got.attempt(), want[i].attempt);
    EXPECT_EQ(AttemptOutcomeName(got.outcome()), AttemptOutcomeName(want[i].outcome));
    EXPECT_NE(got.message().find(want[i].message_part), std::string::npos) << got.message();
    EXPECT_GT(got.ended_ms(), 0);
  }
}

TEST_F(AttemptHistoryTest, LateReportAfterCancelKeepsTheCancelledOutcome) {
  const std::string id = Submit(Request("mesh"), "artist").job_id();
  const v1::LeasedJob a = Lease("w", "d");
  ASSERT_TRUE(scheduler_->CancelJob(id).ok());
  v1::FailJobRequest f;
  f.set_job_id(a.job_id());
  f.set_lease_id(a.lease_id());
  f.mutable_error()->set_code(1);  // CANCELLED, as the worker sends it
  f.mutable_error()->set_message("stopped: cancelled");
  ASSERT_TRUE(scheduler_->Fail(f).ok());
  ASSERT_EQ(Job(id).attempt_history_size(), 1);
  EXPECT_EQ(Job(id).attempt_history(0).outcome(), v1::JobAttempt::OUTCOME_CANCELLED);
}

TEST_F(AttemptHistoryTest, AFollowerShowsItsLeadersAttempts) {
  const std::string leader = Submit(Request("same"), "artist").job_id();
  const std::string follower = Submit(Request("same"), "other").job_id();
  const v1::LeasedJob a = Lease("w1", "d1");
  ASSERT_EQ(a.job_id(), leader);
  ASSERT_EQ(Job(follower).attempt_history_size(), 1);
  EXPECT_EQ(Job(follower).attempt_history(0).worker_id(), "w1");
  ASSERT_TRUE(scheduler_->Complete(Result(a)).ok());
  ASSERT_EQ(Job(follower).attempt_history_size(), 1);
  EXPECT_EQ(Job(follower).attempt_history(0).outcome(), v1::JobAttempt::OUTCOME_SUCCEEDED);
}

TEST_F(AttemptHistoryTest, HistoryIsBoundedOldestDroppedFirst) {
  const std::string id = Submit(Request("mesh"), "artist").job_id();
  // Released leases do not count as attempts, so nothing else stops this.
  const int leases = static_cast<int>(kMaxAttemptHistory) + 8;
  for (int i = 0; i < leases; ++i) {
    const v1::LeasedJob l = Lease("w" + std::to_string(i), "d");
    ASSERT_EQ(l.job_id(), id);
    v1::ReleaseJobRequest r;
    r.set_job_id(l.job_id());
    r.set_lease_id(l.lease_id());
    ASSERT_TRUE(scheduler_->Release(r).ok());
  }
  const v1::Job job = Job(id);
  ASSERT_EQ(job.attempt_history_size(), static_cast<int>(kMaxAttemptHistory));
  EXPECT_EQ(job.attempt_history_dropped(), 8u);
  EXPECT_EQ(job.attempt_history(0).worker_id(), "w8");
  EXPECT_EQ(job.attempt_history(kMaxAttemptHistory - 1).worker_id(), "w" + std::to_string(leases - 1));
}

TEST(AttemptHistory, LongMessagesAreCutOnACharacterBoundary) {
  v1::Job job;
  job.set_attempts(1);
  OpenAttempt(job, "w", "d", 1);
  std::string message;
  for (int i = 0; i < 400; ++i) message += "\xC3\xA9";  // é, 2 bytes each
  CloseAttempt(job, v1::JobAttempt::OUTCOME_FAILED, message, 2);
  const std::string& got = job.attempt_history(0).message();
  EXPECT_LE(got.size(), kMaxAttemptMessageBytes);
  EXPECT_EQ(got.size() % 2, 0u) << "a 2-byte character was split";
  EXPECT_EQ(got, message.substr(0, got.size()));
}

TEST(AttemptHistory, CloseWithoutAnOpenLeaseDoesNothing) {
  v1::Job job;
  CloseAttempt(job, v1::JobAttempt::OUTCOME_FAILED, "x", 2);
  EXPECT_EQ(job.attempt_history_size(), 0);
  EXPECT_EQ(AttemptOutcomeName(v1::JobAttempt::OUTCOME_LEASE_EXPIRED), "lease_expired");
}

}  // namespace
}  // namespace impostor
