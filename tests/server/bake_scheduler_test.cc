#include "server/scheduler/bake_scheduler.h"

#include <atomic>
#include <filesystem>
#include <future>
#include <fstream>
#include <thread>

#include <gtest/gtest.h>
#include <sqlite3.h>

#include "common/request/bake_request.h"
#include "common/error_reason.h"
#include "common/util/sha256.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

// Scheduler over a real SQLite file and blob directory, with a fake clock.
class BakeSchedulerTest : public testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("scheduler_test_" + std::to_string(::getpid()) + "_" +
                                        testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    Reopen();
  }
  void TearDown() override {
    scheduler_.reset();
    fs::remove_all(dir_);
  }
  // Simulates a server restart: everything rebuilt from disk.
  void Reopen() {
    scheduler_.reset();
    jobs_.reset();
    blobs_.reset();
    blobs_ = *BlobStore::Open(dir_ / "blobs");
    jobs_ = *JobStore::Open(dir_ / "jobs.sqlite3");
    scheduler_ = std::make_unique<BakeScheduler>(
        jobs_.get(), blobs_.get(), SchedulerOptions{.lease_timeout_ms = 30'000, .max_attempts = 3, .now_ms = [this] {
                                                      return now_ms_;
                                                    }});
  }

  v1::Digest Store(const std::string& bytes) {
    v1::Digest d;
    d.set_hash(Sha256Hex(bytes));
    d.set_size_bytes(static_cast<int64_t>(bytes.size()));
    EXPECT_TRUE(blobs_->Put({d.hash(), d.size_bytes()}, bytes).ok());
    return d;
  }

  v1::SubmitBakeRequest Request(const std::string& content = "glb bytes") {
    v1::SubmitBakeRequest r;
    r.mutable_mesh()->mutable_entry()->set_path("model.glb");
    *r.mutable_mesh()->mutable_entry()->mutable_digest() = Store(content);
    return r;
  }

  v1::LeasedJob Lease(const std::string& worker = "w1") {
    v1::LeaseJobRequest r;
    r.set_worker_id(worker);
    auto job = scheduler_->Lease(r, std::chrono::steady_clock::now(), nullptr);
    EXPECT_TRUE(job.ok() && job->has_value()) << "expected a job to lease";
    return job.ok() && job->has_value() ? **job : v1::LeasedJob();
  }

  bool NothingToLease() {
    v1::LeaseJobRequest r;
    r.set_worker_id("idle");
    auto job = scheduler_->Lease(r, std::chrono::steady_clock::now(), nullptr);
    return job.ok() && !job->has_value();
  }

  v1::CompleteJobRequest Result(const v1::LeasedJob& job) {
    v1::CompleteJobRequest r;
    r.set_job_id(job.job_id());
    r.set_lease_id(job.lease_id());
    r.mutable_result()->set_cache_key(job.cache_key());
    *r.mutable_result()->mutable_manifest_json() = Store("{\"manifest\": true}");
    v1::MapFile* map = r.mutable_result()->add_maps();
    map->set_file("albedo_alpha.png");
    *map->mutable_digest() = Store("png " + job.cache_key());
    return r;
  }

  fs::path dir_;
  int64_t now_ms_ = 1'000'000;
  std::unique_ptr<BlobStore> blobs_;
  std::unique_ptr<JobStore> jobs_;
  std::unique_ptr<BakeScheduler> scheduler_;
};

TEST_F(BakeSchedulerTest, SecondIdenticalRequestIsACacheHit) {
  auto first = scheduler_->Submit(Request());
  ASSERT_TRUE(first.ok()) << first.status();
  EXPECT_FALSE(first->cached());
  EXPECT_EQ(first->job().state(), v1::JOB_STATE_QUEUED);
  const v1::LeasedJob job = Lease();
  ASSERT_TRUE(scheduler_->Complete(Result(job)).ok());

  auto second = scheduler_->Submit(Request());
  ASSERT_TRUE(second.ok());
  EXPECT_TRUE(second->cached());
  EXPECT_EQ(second->cache_key(), first->cache_key());
  EXPECT_EQ(second->job().state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(second->job().result().maps(0).file(), "albedo_alpha.png");
  EXPECT_TRUE(NothingToLease()) << "a cache hit must not reach the queue";
}

// A worker's device and stage are cut to a byte limit; a cut inside a
// multi-byte character made the stored record invalid UTF-8, which no longer
// parses: DATA_LOSS for the job and a lease sweeper that stopped farm-wide.
TEST_F(BakeSchedulerTest, LongNonAsciiDeviceAndStageLeaveTheJobReadable) {
  std::string accents;
  for (int i = 0; i < 300; ++i) accents += "\xC3\xA9";  // é
  auto submitted = scheduler_->Submit(Request());
  ASSERT_TRUE(submitted.ok()) << submitted.status();
  v1::LeaseJobRequest lease;
  lease.set_worker_id("w1");
  lease.set_device("a" + accents);  // cut at 256 bytes: inside a character
  auto job = scheduler_->Lease(lease, std::chrono::steady_clock::now(), nullptr);
  ASSERT_TRUE(job.ok() && job->has_value()) << job.status();
  v1::ReportProgressRequest p;
  p.set_job_id((*job)->job_id());
  p.set_lease_id((*job)->lease_id());
  p.set_progress(0.5f);
  p.set_stage("a" + accents.substr(0, 80));  // cut at 64 bytes: inside a character
  ASSERT_TRUE(scheduler_->ReportProgress(p).ok());

  Reopen();  // from the database
  auto read = scheduler_->GetJob(submitted->job_id());
  ASSERT_TRUE(read.ok()) << read.status();
  EXPECT_EQ(read->stage().size(), 63u);
  ASSERT_EQ(read->attempt_history_size(), 1);
  EXPECT_EQ(read->attempt_history(0).device().size(), 255u);
  now_ms_ += 31'000;
  EXPECT_TRUE(scheduler_->ExpireLeases().ok()) << "the sweeper reads every running job";
}

// Defence in depth: a job row damaged some other way is skipped by the
// sweeper and the queue (logged once), not a stop for every other job.
TEST_F(BakeSchedulerTest, ADamagedJobRowDoesNotStopTheLeaseSweeper) {
  auto damaged = scheduler_->Submit(Request("mesh one"));
  auto healthy = scheduler_->Submit(Request("mesh two"));
  ASSERT_TRUE(damaged.ok() && healthy.ok());
  const v1::LeasedJob first = Lease("w1");
  const v1::LeasedJob second = Lease("w2");
  ASSERT_FALSE(first.job_id().empty() || second.job_id().empty());
  scheduler_.reset();
  jobs_.reset();
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((dir_ / "jobs.sqlite3").c_str(), &db), SQLITE_OK);
    const std::string sql = "UPDATE jobs SET job = x'0aff' WHERE job_id = '" + first.job_id() + "'";
    EXPECT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK) << sqlite3_errmsg(db);
    sqlite3_close(db);
  }
  Reopen();
  now_ms_ += 31'000;
  ASSERT_TRUE(scheduler_->ExpireLeases().ok());
  auto other = scheduler_->GetJob(second.job_id());
  ASSERT_TRUE(other.ok()) << other.status();
  EXPECT_EQ(other->state(), v1::JOB_STATE_QUEUED) << "the healthy job's expired lease was swept";
  EXPECT_EQ(scheduler_->GetJob(first.job_id()).status().code(), absl::StatusCode::kDataLoss);
}

// A server killed mid-bake takes its local workers with it: at the restart
// their jobs are queued again at once, the attempt not counted; a remote
// worker's lease is left alone (it rides out the restart and reports).
TEST_F(BakeSchedulerTest, ARestartQueuesThePreviousLocalWorkersJobsWithoutCountingTheAttempt) {
  auto local = scheduler_->Submit(Request("local mesh"));
  auto remote = scheduler_->Submit(Request("remote mesh"));
  ASSERT_TRUE(local.ok() && remote.ok());
  const v1::LeasedJob a = Lease("local-0-4242");
  const v1::LeasedJob b = Lease("render-node-7");
  ASSERT_FALSE(a.job_id().empty() || b.job_id().empty());
  Reopen();
  auto released = scheduler_->ReleaseLeasesOfPreviousLocalWorkers();
  ASSERT_TRUE(released.ok()) << released.status();
  EXPECT_EQ(*released, 1);
  auto requeued = scheduler_->GetJob(a.job_id());
  ASSERT_TRUE(requeued.ok());
  EXPECT_EQ(requeued->state(), v1::JOB_STATE_QUEUED);
  EXPECT_EQ(requeued->attempts(), 0u);
  ASSERT_EQ(requeued->attempt_history_size(), 1);
  EXPECT_EQ(requeued->attempt_history(0).outcome(), v1::JobAttempt::OUTCOME_RELEASED);
  EXPECT_EQ(scheduler_->GetJob(b.job_id())->state(), v1::JOB_STATE_RUNNING);
  const v1::LeasedJob again = Lease("local-0-5151");
  EXPECT_EQ(again.job_id(), a.job_id()) << "leased again at once, not after the lease timeout";
  EXPECT_EQ(again.attempt(), 1u);
}

// A worker id is bounded (it lands in every job it leases and in a metrics
// label) and belongs to the worker token using it: another token cannot
// lease under it to get that worker paused or its failures counted.
TEST_F(BakeSchedulerTest, AWorkerIdIsBoundedAndBelongsToTheTokenUsingIt) {
  ASSERT_TRUE(scheduler_->Submit(Request("one")).ok());
  ASSERT_TRUE(scheduler_->Submit(Request("two")).ok());
  v1::LeaseJobRequest r;
  r.set_worker_id(std::string(129, 'w'));
  const auto now = std::chrono::steady_clock::now();
  auto too_long = scheduler_->Lease(r, now, nullptr, "render-node-1");
  EXPECT_EQ(too_long.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(too_long.status().message().find("worker_id: 129 bytes, the limit is 128"), std::string::npos)
      << too_long.status();

  r.set_worker_id("node-1");
  auto first = scheduler_->Lease(r, now, nullptr, "render-node-1");
  ASSERT_TRUE(first.ok() && first->has_value()) << first.status();
  auto hijack = scheduler_->Lease(r, now, nullptr, "render-node-2");
  EXPECT_EQ(hijack.status().code(), absl::StatusCode::kPermissionDenied) << hijack.status();
  EXPECT_NE(hijack.status().message().find("in use by another worker token"), std::string::npos) << hijack.status();
  // Its own token goes on; once the id has been quiet for a lease timeout,
  // another token may take it (a renamed token on the same machine).
  auto again = scheduler_->Lease(r, now, nullptr, "render-node-1");
  ASSERT_TRUE(again.ok()) << again.status();
  now_ms_ += 31'000;
  auto later = scheduler_->Lease(r, now, nullptr, "render-node-2");
  EXPECT_TRUE(later.ok()) << later.status();
}

// A LeaseJob whose caller gave up (its deadline passed while the call
// waited behind a database outage) claims nothing; one that gave up while
// the claim itself waited hands the job back, the attempt not counted.
TEST_F(BakeSchedulerTest, ALeaseWhoseCallerIsGoneGrantsNothingAndLosesNoAttempt) {
  auto submitted = scheduler_->Submit(Request());
  ASSERT_TRUE(submitted.ok());
  v1::LeaseJobRequest r;
  r.set_worker_id("w1");
  const auto now = std::chrono::steady_clock::now();
  auto gone = scheduler_->Lease(r, now, [] { return true; });
  ASSERT_TRUE(gone.ok()) << gone.status();
  EXPECT_FALSE(gone->has_value());
  int asked = 0;
  auto gone_during_claim = scheduler_->Lease(r, now, [&asked] { return ++asked > 1; });
  ASSERT_TRUE(gone_during_claim.ok()) << gone_during_claim.status();
  EXPECT_FALSE(gone_during_claim->has_value());
  auto job = scheduler_->GetJob(submitted->job_id());
  ASSERT_TRUE(job.ok());
  EXPECT_EQ(job->state(), v1::JOB_STATE_QUEUED);
  EXPECT_EQ(job->attempts(), 0u);
  const v1::LeasedJob leased = Lease("w1");
  EXPECT_EQ(leased.job_id(), submitted->job_id());
  EXPECT_EQ(leased.attempt(), 1u) << "the unclaimed lease cost nothing";
}

TEST_F(BakeSchedulerTest, LookupFindsOnlyWhatIsBaked) {
  v1::SubmitBakeRequest request = Request();
  auto miss = scheduler_->Lookup(request);
  ASSERT_TRUE(miss.ok()) << miss.status();
  EXPECT_FALSE(miss->found());
  ASSERT_TRUE(scheduler_->Submit(request).ok());
  EXPECT_FALSE(scheduler_->Lookup(request)->found()) << "queued is not baked";
  ASSERT_TRUE(scheduler_->Complete(Result(Lease())).ok());
  auto hit = scheduler_->Lookup(request);
  EXPECT_TRUE(hit->found());
  EXPECT_EQ(hit->cache_key(), miss->cache_key());
  EXPECT_EQ(hit->result().maps(0).file(), "albedo_alpha.png");
  EXPECT_TRUE(NothingToLease()) << "a lookup never queues a bake";
  request.mutable_parameters()->set_frames(100);
  EXPECT_EQ(scheduler_->Lookup(request).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST_F(BakeSchedulerTest, IdenticalInFlightRequestsShareOneBake) {
  auto a = scheduler_->Submit(Request());
  auto b = scheduler_->Submit(Request());
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_NE(a->job_id(), b->job_id()) << "every requester gets its own job";
  EXPECT_EQ(a->cache_key(), b->cache_key());
  const v1::LeasedJob job = Lease();
  EXPECT_EQ(job.job_id(), a->job_id());
  EXPECT_TRUE(NothingToLease()) << "one bake for both";
  // A third requester joins while it runs, and sees its progress.
  auto c = scheduler_->Submit(Request());
  v1::ReportProgressRequest p;
  p.set_job_id(job.job_id());
  p.set_lease_id(job.lease_id());
  p.set_progress(0.5f);
  p.set_stage("render");
  ASSERT_TRUE(scheduler_->ReportProgress(p).ok());
  auto seen = scheduler_->GetJob(c->job_id());
  EXPECT_EQ(seen->state(), v1::JOB_STATE_RUNNING);
  EXPECT_EQ(seen->stage(), "render");
  ASSERT_TRUE(scheduler_->Complete(Result(job)).ok());
  for (const auto& id : {a->job_id(), b->job_id(), c->job_id()}) {
    auto done = scheduler_->GetJob(id);
    EXPECT_EQ(done->state(), v1::JOB_STATE_SUCCEEDED) << id;
    EXPECT_EQ(done->result().maps(0).file(), "albedo_alpha.png") << id;
  }
}

TEST_F(BakeSchedulerTest, CancellingOneSharerKeepsTheBakeForTheOthers) {
  auto leader = scheduler_->Submit(Request());
  auto follower = scheduler_->Submit(Request());
  const v1::LeasedJob job = Lease();
  // The first requester gives up; the second still wants the bake.
  EXPECT_EQ(scheduler_->CancelJob(leader->job_id())->state(), v1::JOB_STATE_CANCELLED);
  v1::ReportProgressRequest p;
  p.set_job_id(job.job_id());
  p.set_lease_id(job.lease_id());
  EXPECT_FALSE(scheduler_->ReportProgress(p)->cancel_requested()) << "someone still wants it";
  ASSERT_TRUE(scheduler_->Complete(Result(job)).ok());
  EXPECT_EQ(scheduler_->GetJob(follower->job_id())->state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(scheduler_->GetJob(leader->job_id())->state(), v1::JOB_STATE_CANCELLED);
}

TEST_F(BakeSchedulerTest, TheBakeStopsWhenNobodyWantsIt) {
  auto a = scheduler_->Submit(Request());
  auto b = scheduler_->Submit(Request());
  const v1::LeasedJob job = Lease();
  v1::ReportProgressRequest p;
  p.set_job_id(job.job_id());
  p.set_lease_id(job.lease_id());
  ASSERT_TRUE(scheduler_->CancelJob(b->job_id()).ok());
  EXPECT_FALSE(scheduler_->ReportProgress(p)->cancel_requested());
  ASSERT_TRUE(scheduler_->CancelJob(a->job_id()).ok());
  EXPECT_TRUE(scheduler_->ReportProgress(p)->cancel_requested()) << "last requester gone: stop the worker";
  EXPECT_EQ(scheduler_->GetJob(a->job_id())->state(), v1::JOB_STATE_CANCELLED);
  EXPECT_EQ(scheduler_->GetJob(b->job_id())->state(), v1::JOB_STATE_CANCELLED);
  // A new request for the same key starts a fresh bake.
  auto fresh = scheduler_->Submit(Request());
  EXPECT_EQ(fresh->job().state(), v1::JOB_STATE_QUEUED);
  EXPECT_EQ(Lease().job_id(), fresh->job_id());
}

TEST_F(BakeSchedulerTest, PendingLimitsAnswerResourceExhausted) {
  scheduler_.reset();
  scheduler_ = std::make_unique<BakeScheduler>(
      jobs_.get(), blobs_.get(),
      SchedulerOptions{.max_pending_jobs = 3, .max_pending_per_client = 2, .now_ms = [this] { return now_ms_; }});
  ASSERT_TRUE(scheduler_->Submit(Request("a"), "ci").ok());
  ASSERT_TRUE(scheduler_->Submit(Request("b"), "ci").ok());
  auto third = scheduler_->Submit(Request("c"), "ci");
  ASSERT_EQ(third.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_NE(third.status().message().find("limit per client is 2"), std::string::npos) << third.status();
  EXPECT_EQ(ErrorReasonOf(third.status()), "CLIENT_PENDING_JOBS");
  ASSERT_TRUE(scheduler_->Submit(Request("c"), "artist").ok()) << "another client is not starved";
  auto fourth = scheduler_->Submit(Request("d"), "artist");
  ASSERT_EQ(fourth.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_NE(fourth.status().message().find("the limit is 3"), std::string::npos) << fourth.status();
  EXPECT_EQ(ErrorReasonOf(fourth.status()), "FARM_PENDING_JOBS");
  // Finishing work frees room.
  ASSERT_TRUE(scheduler_->Complete(Result(Lease())).ok());
  EXPECT_TRUE(scheduler_->Submit(Request("d"), "artist").ok());
}

TEST_F(BakeSchedulerTest, MissingInputBlobIsAFailedPrecondition) {
  v1::SubmitBakeRequest r = Request();
  r.mutable_mesh()->mutable_entry()->mutable_digest()->set_hash(std::string(64, 'e'));
  auto s = scheduler_->Submit(r);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(s.status().message().find("mesh.entry"), std::string::npos) << s.status();
  EXPECT_EQ(ErrorReasonOf(s.status()), "INPUT_BLOB_MISSING");
}

TEST_F(BakeSchedulerTest, ExpiredLeaseRequeuesAndStaleWorkerIsRefused) {
  ASSERT_TRUE(scheduler_->Submit(Request()).ok());
  const v1::LeasedJob first = Lease("dead-worker");
  now_ms_ += 29'000;
  ASSERT_TRUE(scheduler_->ExpireLeases().ok());
  EXPECT_TRUE(NothingToLease()) << "lease has not expired yet";
  now_ms_ += 2'000;
  ASSERT_TRUE(scheduler_->ExpireLeases().ok());
  const v1::LeasedJob second = Lease("live-worker");
  EXPECT_EQ(second.job_id(), first.job_id());
  EXPECT_EQ(second.attempt(), 2u);
  const absl::Status stale = scheduler_->Complete(Result(first));
  EXPECT_EQ(stale.code(), absl::StatusCode::kFailedPrecondition) << stale;
  EXPECT_TRUE(scheduler_->Complete(Result(second)).ok());
  EXPECT_EQ(scheduler_->GetJob(first.job_id())->state(), v1::JOB_STATE_SUCCEEDED);
}

TEST_F(BakeSchedulerTest, HeartbeatsKeepTheLease) {
  ASSERT_TRUE(scheduler_->Submit(Request()).ok());
  const v1::LeasedJob job = Lease();
  for (int i = 0; i < 5; ++i) {
    now_ms_ += 20'000;
    v1::ReportProgressRequest p;
    p.set_job_id(job.job_id());
    p.set_lease_id(job.lease_id());
    p.set_progress(0.1f * i);
    p.set_stage("render");
    ASSERT_TRUE(scheduler_->ReportProgress(p).ok());
    ASSERT_TRUE(scheduler_->ExpireLeases().ok());
  }
  auto j = scheduler_->GetJob(job.job_id());
  EXPECT_EQ(j->state(), v1::JOB_STATE_RUNNING);
  EXPECT_EQ(j->stage(), "render");
}

TEST_F(BakeSchedulerTest, RunsOutOfAttemptsAndSaysSo) {
  ASSERT_TRUE(scheduler_->Submit(Request()).ok());
  std::string job_id;
  for (int attempt = 1; attempt <= 3; ++attempt) {
    const v1::LeasedJob job = Lease();
    job_id = job.job_id();
    v1::FailJobRequest f;
    f.set_job_id(job.job_id());
    f.set_lease_id(job.lease_id());
    f.set_retryable(true);
    f.mutable_error()->set_code(13);
    f.mutable_error()->set_message("device lost");
    ASSERT_TRUE(scheduler_->Fail(f).ok());
  }
  auto j = scheduler_->GetJob(job_id);
  EXPECT_EQ(j->state(), v1::JOB_STATE_FAILED);
  EXPECT_NE(j->error().message().find("failed after 3 attempts"), std::string::npos) << j->error().message();
  EXPECT_NE(j->error().message().find("device lost"), std::string::npos);
  EXPECT_TRUE(NothingToLease());
}

TEST_F(BakeSchedulerTest, BadInputFailsAtOnce) {
  ASSERT_TRUE(scheduler_->Submit(Request()).ok());
  const v1::LeasedJob job = Lease();
  v1::FailJobRequest f;
  f.set_job_id(job.job_id());
  f.set_lease_id(job.lease_id());
  f.set_retryable(false);
  f.mutable_error()->set_code(3);
  f.mutable_error()->set_message("glTF: invalid JSON");
  ASSERT_TRUE(scheduler_->Fail(f).ok());
  auto j = scheduler_->GetJob(job.job_id());
  EXPECT_EQ(j->state(), v1::JOB_STATE_FAILED);
  EXPECT_EQ(j->error().code(), 3);
  EXPECT_EQ(j->error().message(), "glTF: invalid JSON");
}

TEST_F(BakeSchedulerTest, AFailJobNeedsAFailureCodeAndIsCappedAtAScreenful) {
  ASSERT_TRUE(scheduler_->Submit(Request()).ok());
  const v1::LeasedJob job = Lease();
  v1::FailJobRequest f;
  f.set_job_id(job.job_id());
  f.set_lease_id(job.lease_id());
  for (const int code : {0, 17, 999, -1}) {
    f.mutable_error()->set_code(code);
    const absl::Status refused = scheduler_->Fail(f);
    EXPECT_EQ(refused.code(), absl::StatusCode::kInvalidArgument) << code;
    EXPECT_NE(refused.message().find("error.code"), std::string::npos) << refused;
  }
  f.mutable_error()->set_code(13);
  f.mutable_error()->set_message(std::string(8 << 20, 'x'));
  ASSERT_TRUE(scheduler_->Fail(f).ok());
  auto j = scheduler_->GetJob(job.job_id());
  ASSERT_TRUE(j.ok());
  EXPECT_EQ(j->state(), v1::JOB_STATE_FAILED);
  EXPECT_LE(j->error().message().size(), BakeScheduler::kMaxJobErrorBytes);
}

TEST_F(BakeSchedulerTest, CancelReachesTheWorkerThroughItsNextReport) {
  auto s = scheduler_->Submit(Request());
  const v1::LeasedJob job = Lease();
  auto cancelled = scheduler_->CancelJob(s->job_id());
  ASSERT_TRUE(cancelled.ok());
  EXPECT_EQ(cancelled->state(), v1::JOB_STATE_CANCELLED);
  v1::ReportProgressRequest p;
  p.set_job_id(job.job_id());
  p.set_lease_id(job.lease_id());
  auto r = scheduler_->ReportProgress(p);
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(r->cancel_requested());
}

TEST_F(BakeSchedulerTest, AcceptedJobsSurviveARestart) {
  auto queued = scheduler_->Submit(Request("one"));
  auto running = scheduler_->Submit(Request("two"));
  const v1::LeasedJob lease = Lease();
  Reopen();
  auto q = scheduler_->GetJob(queued->job_id());
  ASSERT_TRUE(q.ok()) << q.status();
  EXPECT_EQ(q->state(), v1::JOB_STATE_RUNNING) << "the first job submitted was leased before the restart";
  EXPECT_EQ(scheduler_->GetJob(running->job_id())->state(), v1::JOB_STATE_QUEUED);
  EXPECT_TRUE(scheduler_->Complete(Result(lease)).ok()) << "a lease survives the restart";
  const v1::LeasedJob next = Lease();
  EXPECT_EQ(next.job_id(), running->job_id());
}

TEST_F(BakeSchedulerTest, CachedResultWithCorruptBlobIsRebaked) {
  auto s = scheduler_->Submit(Request());
  const v1::CompleteJobRequest result = Result(Lease());
  ASSERT_TRUE(scheduler_->Complete(result).ok());
  const auto& map = result.result().maps(0).digest();
  {
    std::ofstream f(blobs_->PathFor({map.hash(), map.size_bytes()}), std::ios::binary | std::ios::trunc);
    f << std::string(static_cast<size_t>(map.size_bytes()), 'X');  // same size, wrong bytes
  }
  auto again = scheduler_->Submit(Request());
  ASSERT_TRUE(again.ok());
  EXPECT_FALSE(again->cached()) << "rotten bytes must never be served";
  EXPECT_FALSE(blobs_->Contains({map.hash(), map.size_bytes()})) << "the corrupt blob is quarantined";
}

// A game fetching by key learns its result was lost, not that it was never
// baked; still NOT_FOUND (a miss: the client bakes again), and only once.
TEST_F(BakeSchedulerTest, GetResultOfADamagedResultSaysItWasRemoved) {
  ASSERT_TRUE(scheduler_->Submit(Request()).ok());
  const v1::CompleteJobRequest result = Result(Lease());
  ASSERT_TRUE(scheduler_->Complete(result).ok());
  const std::string key = result.result().cache_key();
  ASSERT_TRUE(scheduler_->GetResult(key).ok());
  const auto& map = result.result().maps(0).digest();
  {
    std::ofstream f(blobs_->PathFor({map.hash(), map.size_bytes()}), std::ios::binary | std::ios::trunc);
    f << std::string(static_cast<size_t>(map.size_bytes()), 'X');
  }
  auto lost = scheduler_->GetResult(key);
  EXPECT_EQ(lost.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(lost.status().message().find("was damaged on the server"), std::string::npos) << lost.status();
  EXPECT_NE(lost.status().message().find("submit the bake again"), std::string::npos) << lost.status();
  auto later = scheduler_->GetResult(key);
  EXPECT_EQ(later.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(later.status().message().find("nothing baked under"), std::string::npos) << later.status();
}

TEST_F(BakeSchedulerTest, CachedResultWithMissingBlobIsRebaked) {
  auto s = scheduler_->Submit(Request());
  const v1::LeasedJob job = Lease();
  const v1::CompleteJobRequest result = Result(job);
  ASSERT_TRUE(scheduler_->Complete(result).ok());
  const auto& map = result.result().maps(0).digest();
  fs::remove(blobs_->PathFor({map.hash(), map.size_bytes()}));
  auto again = scheduler_->Submit(Request());
  ASSERT_TRUE(again.ok());
  EXPECT_FALSE(again->cached());
  EXPECT_EQ(again->job().state(), v1::JOB_STATE_QUEUED);
  EXPECT_EQ(scheduler_->GetResult(s->cache_key()).status().code(), absl::StatusCode::kNotFound);
}

TEST_F(BakeSchedulerTest, CompleteChecksTheResult) {
  ASSERT_TRUE(scheduler_->Submit(Request()).ok());
  const v1::LeasedJob job = Lease();
  v1::CompleteJobRequest wrong_key = Result(job);
  wrong_key.mutable_result()->set_cache_key(std::string(64, '0'));
  EXPECT_EQ(scheduler_->Complete(wrong_key).code(), absl::StatusCode::kInvalidArgument);
  v1::CompleteJobRequest missing_blob = Result(job);
  missing_blob.mutable_result()->mutable_maps(0)->mutable_digest()->set_hash(std::string(64, 'b'));
  EXPECT_EQ(scheduler_->Complete(missing_blob).code(), absl::StatusCode::kFailedPrecondition);
}

TEST_F(BakeSchedulerTest, LongPollWakesWhenAJobArrives) {
  // Lease calls `caller_gone` (under the scheduler's lock) each time it has
  // found nothing and is about to wait: the first call tells this test the
  // poller is waiting, and Submit (which needs the lock) cannot slip in
  // before the wait begins.
  std::promise<void> waiting;
  std::atomic<int> empty_checks{0};
  std::optional<v1::LeasedJob> got;
  std::thread worker([&] {
    v1::LeaseJobRequest r;
    r.set_worker_id("poller");
    auto job = scheduler_->Lease(r, std::chrono::steady_clock::now() + std::chrono::seconds(30), [&] {
      if (empty_checks.fetch_add(1) == 0) waiting.set_value();
      return false;
    });
    if (job.ok()) got = *job;
  });
  waiting.get_future().wait();
  auto s = scheduler_->Submit(Request());
  worker.join();
  ASSERT_TRUE(s.ok()) << s.status();
  ASSERT_TRUE(got.has_value()) << "the waiting poller returned without the job";
  EXPECT_EQ(got->job_id(), s->job_id());
  EXPECT_GE(empty_checks.load(), 1);
}

TEST_F(BakeSchedulerTest, RejectsMalformedWorkerRequests) {
  v1::LeaseJobRequest no_id;
  EXPECT_EQ(scheduler_->Lease(no_id, std::chrono::steady_clock::now(), nullptr).status().code(),
            absl::StatusCode::kInvalidArgument);
  v1::LeaseJobRequest long_wait;
  long_wait.set_worker_id("w");
  long_wait.set_wait_seconds(3600);
  EXPECT_EQ(scheduler_->Lease(long_wait, std::chrono::steady_clock::now(), nullptr).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(scheduler_->GetJob("").status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(scheduler_->GetJob("job-nope").status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(scheduler_->GetResult("not-a-key").status().code(), absl::StatusCode::kInvalidArgument);
}

// A server that died between saving a finished leader and settling its
// followers left them waiting; the next lease sweep settles them.
TEST_F(BakeSchedulerTest, TheLeaseSweepSettlesFollowersOfAFinishedLeader) {
  auto record = [](const std::string& id, v1::JobState state, const std::string& leader) {
    JobRecord r;
    r.job.set_job_id(id);
    r.job.set_cache_key("k-stranded");
    r.job.set_state(state);
    r.job.set_created_ms(1);
    r.job.mutable_error()->set_message(state == v1::JOB_STATE_FAILED ? "the mesh has no triangles" : "");
    r.mesh.mutable_entry()->set_path("model.glb");
    r.mesh.mutable_entry()->mutable_digest()->set_hash("in-" + id);
    r.parameters.set_frames(8);
    r.client_id = "c";
    r.leader_job_id = leader;
    return r;
  };
  ASSERT_TRUE(jobs_->Insert(record("leader", v1::JOB_STATE_FAILED, "")).ok());
  ASSERT_TRUE(jobs_->Insert(record("follower", v1::JOB_STATE_QUEUED, "leader")).ok());
  // GetJob already shows a follower its leader's state; the row itself
  // stayed QUEUED (counted as pending, never retired) until the sweep.
  auto row = [&] { return (*jobs_->Get("follower"))->job; };
  ASSERT_EQ(row().state(), v1::JOB_STATE_QUEUED);
  ASSERT_TRUE(scheduler_->ExpireLeases().ok());
  EXPECT_EQ(row().state(), v1::JOB_STATE_FAILED);
  EXPECT_EQ(row().error().message(), "the mesh has no triangles");
  auto left = jobs_->FinishedLeadersWithWaitingFollowers(10);
  ASSERT_TRUE(left.ok());
  EXPECT_TRUE(left->empty());
}

}  // namespace
}  // namespace impostor
