// Two BakeSchedulers (two server replicas) on one PostgreSQL database and
// one blob directory: every job is leased once however the replicas race,
// identical requests share one bake across replicas, a job submitted on one
// is completed through the other, and a stale replica's writes change
// nothing.
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <set>
#include <thread>

#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "common/util/sha256.h"
#include "server/scheduler/bake_scheduler.h"
#include "tests/server/job_store_test_engines.h"

namespace impostor::testing {
namespace {

class MultiReplica : public ::testing::Test {
 protected:
  void SetUp() override {
    url_ = FreshPostgresDatabase();
    ASSERT_FALSE(url_.empty());
    db_ = DatabaseName(url_);
    dir_ = std::filesystem::temp_directory_path() / ("multi_replica_" + std::to_string(::getpid()) + "_" +
                                                     ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    auto blobs = BlobStore::Open(dir_);
    ASSERT_TRUE(blobs.ok());
    blobs_ = std::move(*blobs);
    for (int i = 0; i < 2; ++i) {
      auto store = PostgresJobStore::Open({.url = url_, .pool_size = 4});
      ASSERT_TRUE(store.ok()) << store.status();
      stores_[i] = std::move(*store);
      replicas_[i] = std::make_unique<BakeScheduler>(
          stores_[i].get(), blobs_.get(),
          SchedulerOptions{.lease_timeout_ms = 30'000, .max_attempts = 3, .now_ms = [this] { return now_ms_.load(); }});
    }
  }
  void TearDown() override {
    for (auto& r : replicas_) r.reset();
    for (auto& s : stores_) s.reset();
    std::filesystem::remove_all(dir_);
  }
  v1::Digest Store(const std::string& bytes) {
    v1::Digest d;
    d.set_hash(Sha256Hex(bytes));
    d.set_size_bytes(static_cast<int64_t>(bytes.size()));
    EXPECT_TRUE(blobs_->Put({d.hash(), d.size_bytes()}, bytes).ok());
    return d;
  }
  v1::SubmitBakeRequest Request(const std::string& content) {
    v1::SubmitBakeRequest r;
    r.mutable_mesh()->mutable_entry()->set_path("model.glb");
    *r.mutable_mesh()->mutable_entry()->mutable_digest() = Store(content);
    return r;
  }
  std::optional<v1::LeasedJob> Lease(int replica, const std::string& worker) {
    v1::LeaseJobRequest r;
    r.set_worker_id(worker);
    auto job = replicas_[replica]->Lease(r, std::chrono::steady_clock::now(), nullptr);
    EXPECT_TRUE(job.ok()) << job.status();
    return job.ok() ? *job : std::nullopt;
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
  int64_t SqlCount(const std::string& sql) {
    auto out = SharedPostgres()->Query(db_, sql);
    EXPECT_TRUE(out.ok()) << out.status();
    return out.ok() ? std::stoll(*out) : -1;
  }

  std::string url_, db_;
  std::filesystem::path dir_;
  std::atomic<int64_t> now_ms_{1'000'000};
  std::unique_ptr<BlobStore> blobs_;
  std::unique_ptr<JobStore> stores_[2];
  std::unique_ptr<BakeScheduler> replicas_[2];
};

TEST_F(MultiReplica, TwoReplicasLeaseThreeThousandJobsEachExactlyOnce) {
  constexpr int kJobs = 3000;
  // The queue, written straight into the database (three clients).
  for (int i = 0; i < kJobs; ++i) {
    JobRecord r;
    r.job.set_job_id(absl::StrCat("job-", i));
    r.job.set_cache_key(absl::StrCat("key-", i));
    r.job.set_state(v1::JOB_STATE_QUEUED);
    r.job.set_stage("queued");
    r.job.set_created_ms(i);
    r.client_id = absl::StrCat("client-", i % 3);
    ASSERT_TRUE(stores_[0]->Insert(r).ok());
  }
  // Two workers per replica lease as fast as they can until the queue is
  // empty.
  std::mutex mu;
  std::vector<std::string> leased;
  std::atomic<int> per_replica[2] = {0, 0};
  const auto start = std::chrono::steady_clock::now();
  std::vector<std::thread> workers;
  for (int replica = 0; replica < 2; ++replica) {
    for (int w = 0; w < 2; ++w) {
      workers.emplace_back([&, replica, w] {
        const std::string worker = absl::StrCat("r", replica, "-w", w);
        while (true) {
          auto job = Lease(replica, worker);
          if (!job.has_value()) {
            // Empty for this replica's look; done when the database agrees.
            auto pending = stores_[replica]->CountPending("");
            auto running = stores_[replica]->RunningPerClient();
            int64_t busy = 0;
            for (const auto& [client, n] : *running) busy += n;
            if (*pending - busy == 0) return;
            continue;
          }
          ++per_replica[replica];
          std::lock_guard lock(mu);
          leased.push_back(job->job_id());
        }
      });
    }
  }
  for (auto& t : workers) t.join();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("[ multi-replica ] %d leases in %.2f s (%.0f leases/s): replica A %d, replica B %d\n", kJobs, seconds,
              kJobs / seconds, per_replica[0].load(), per_replica[1].load());
  // Every job handed out once, to one worker.
  EXPECT_EQ(leased.size(), static_cast<size_t>(kJobs));
  EXPECT_EQ(std::set<std::string>(leased.begin(), leased.end()).size(), static_cast<size_t>(kJobs));
  EXPECT_GT(per_replica[0].load(), 0);
  EXPECT_GT(per_replica[1].load(), 0);
  // And from the database: all running, each claimed once (one version
  // bump, one distinct lease).
  EXPECT_EQ(SqlCount("SELECT count(*) FROM jobs WHERE state = 2"), kJobs);
  EXPECT_EQ(SqlCount("SELECT count(*) FROM jobs WHERE row_version <> 1"), 0);
  EXPECT_EQ(SqlCount("SELECT count(DISTINCT lease_id) FROM jobs"), kJobs);
}

TEST_F(MultiReplica, IdenticalRequestsAtBothReplicasShareOneBake) {
  const v1::SubmitBakeRequest request = Request("the same mesh");
  std::vector<std::thread> threads;
  std::atomic<int> ok{0};
  for (int i = 0; i < 8; ++i) {
    threads.emplace_back([&, i] {
      auto r = replicas_[i % 2]->Submit(request, absl::StrCat("client-", i));
      EXPECT_TRUE(r.ok()) << r.status();
      if (r.ok()) ++ok;
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(ok.load(), 8);
  EXPECT_EQ(SqlCount("SELECT count(*) FROM jobs WHERE leader_job_id = ''"), 1);
  EXPECT_EQ(SqlCount("SELECT count(*) FROM jobs WHERE leader_job_id <> ''"), 7);
  // One lease serves all eight, whichever replica hands it out.
  auto job = Lease(1, "w1");
  ASSERT_TRUE(job.has_value());
  EXPECT_FALSE(Lease(0, "w2").has_value());
  ASSERT_TRUE(replicas_[0]->Complete(Result(*job)).ok());
  EXPECT_EQ(SqlCount("SELECT count(*) FROM jobs WHERE state = 3"), 8);
}

TEST_F(MultiReplica, SubmittedOnOneWatchedAndCompletedThroughTheOther) {
  const uint64_t seen = replicas_[1]->change_count();
  auto submitted = replicas_[0]->Submit(Request("mesh a"), "client");
  ASSERT_TRUE(submitted.ok()) << submitted.status();
  // Replica B's waiters hear of it through NOTIFY (the wait's limit is only
  // a backstop for a loaded machine).
  EXPECT_NE(replicas_[1]->WaitForChange(seen, std::chrono::steady_clock::now() + std::chrono::seconds(60)), seen);
  auto job = Lease(1, "w-b");
  ASSERT_TRUE(job.has_value());
  EXPECT_EQ(job->job_id(), submitted->job_id());
  v1::ReportProgressRequest progress;
  progress.set_job_id(job->job_id());
  progress.set_lease_id(job->lease_id());
  progress.set_progress(0.5f);
  ASSERT_TRUE(replicas_[0]->ReportProgress(progress).ok());
  ASSERT_TRUE(replicas_[0]->Complete(Result(*job)).ok());
  auto seen_on_b = replicas_[1]->GetJob(submitted->job_id());
  ASSERT_TRUE(seen_on_b.ok());
  EXPECT_EQ(seen_on_b->state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_TRUE(seen_on_b->has_result());
}

TEST_F(MultiReplica, AStaleReplicasLeaseChangesNothing) {
  auto submitted = replicas_[0]->Submit(Request("mesh b"), "client");
  ASSERT_TRUE(submitted.ok());
  auto first = Lease(0, "w-a");
  ASSERT_TRUE(first.has_value());
  // The lease expires; replica B (the maintainer) requeues it and leases it
  // to another worker.
  now_ms_ += 31'000;
  ASSERT_TRUE(*stores_[1]->HoldMaintenanceLock() || *stores_[0]->HoldMaintenanceLock());
  const int sweeper = *stores_[1]->HoldMaintenanceLock() ? 1 : 0;
  ASSERT_TRUE(replicas_[sweeper]->ExpireLeases().ok());
  // The other replica's sweep does nothing: not the maintainer.
  ASSERT_TRUE(replicas_[1 - sweeper]->ExpireLeases().ok());
  auto second = Lease(1, "w-b");
  ASSERT_TRUE(second.has_value());
  EXPECT_EQ(second->attempt(), 2u);
  // The first worker comes back through replica A: its lease is gone.
  EXPECT_EQ(replicas_[0]->Complete(Result(*first)).code(), absl::StatusCode::kFailedPrecondition);
  v1::FailJobRequest fail;
  fail.set_job_id(first->job_id());
  fail.set_lease_id(first->lease_id());
  fail.set_retryable(true);
  fail.mutable_error()->set_code(14);
  fail.mutable_error()->set_message("device lost");
  EXPECT_EQ(replicas_[0]->Fail(fail).code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(SqlCount(absl::StrCat("SELECT count(*) FROM jobs WHERE state = 2 AND lease_id = '", second->lease_id(),
                                  "'")),
            1);
  ASSERT_TRUE(replicas_[1]->Complete(Result(*second)).ok());
}

// The rest of "watched, cancelled and completed through another": a job
// submitted and leased through replica A is cancelled through replica B. A's
// waiters wake (NOTIFY), A answers the job as cancelled, and the worker's
// next heartbeat through A tells it to stop.
TEST_F(MultiReplica, SubmittedOnOneCancelledThroughTheOtherStopsItsWorker) {
  auto submitted = replicas_[0]->Submit(Request("mesh c"), "client");
  ASSERT_TRUE(submitted.ok()) << submitted.status();
  auto job = Lease(0, "w-a");
  ASSERT_TRUE(job.has_value());
  v1::ReportProgressRequest progress;
  progress.set_job_id(job->job_id());
  progress.set_lease_id(job->lease_id());
  progress.set_progress(0.25f);
  auto before = replicas_[0]->ReportProgress(progress);
  ASSERT_TRUE(before.ok()) << before.status();
  EXPECT_FALSE(before->cancel_requested());

  const uint64_t seen = replicas_[0]->change_count();
  auto cancelled = replicas_[1]->CancelJob(submitted->job_id());
  ASSERT_TRUE(cancelled.ok()) << cancelled.status();
  EXPECT_EQ(cancelled->state(), v1::JOB_STATE_CANCELLED);
  EXPECT_NE(replicas_[0]->WaitForChange(seen, std::chrono::steady_clock::now() + std::chrono::seconds(60)), seen);
  auto on_a = replicas_[0]->GetJob(submitted->job_id());
  ASSERT_TRUE(on_a.ok()) << on_a.status();
  EXPECT_EQ(on_a->state(), v1::JOB_STATE_CANCELLED);
  progress.set_progress(0.5f);
  auto after = replicas_[0]->ReportProgress(progress);
  ASSERT_TRUE(after.ok()) << after.status();
  EXPECT_TRUE(after->cancel_requested());
  EXPECT_EQ(SqlCount(absl::StrCat("SELECT count(*) FROM jobs WHERE state = ", int{v1::JOB_STATE_CANCELLED})), 1);
}

// Replicas share the blob directory as well as the database, and each
// process counts only the blobs it stored and removed itself. The replica
// that evicts (the maintenance-lock holder) must go by the directory:
// uploads through the other replica count against the cap, and blobs
// another replica removed no longer do.
TEST_F(MultiReplica, TheEvictingReplicaCountsWhatTheOthersStoredAndRemoved) {
  constexpr int64_t kCap = 10'000;
  // Two processes' views of one directory, each with its own store.
  auto blobs_a = BlobStore::Open(dir_ / "shared");
  auto blobs_b = BlobStore::Open(dir_ / "shared");
  ASSERT_TRUE(blobs_a.ok() && blobs_b.ok());
  auto store_a = PostgresJobStore::Open({.url = url_, .pool_size = 2});
  auto store_b = PostgresJobStore::Open({.url = url_, .pool_size = 2});
  ASSERT_TRUE(store_a.ok() && store_b.ok());
  const SchedulerOptions options{
      .store_max_bytes = kCap, .eviction_grace_ms = 0, .now_ms = [this] { return now_ms_.load(); }};
  auto a = std::make_unique<BakeScheduler>(store_a->get(), blobs_a->get(), options);
  BakeScheduler b(store_b->get(), blobs_b->get(), options);
  ASSERT_TRUE(*(*store_a)->HoldMaintenanceLock()) << "replica A evicts";
  auto on_disk = [&] {
    int64_t total = 0;
    for (const auto& blob : (*blobs_b)->List()) total += blob.size_bytes;
    return total;
  };
  auto put_old = [&](BlobStore& blobs, const std::string& bytes) {
    const BlobDigest d{Sha256Hex(bytes), static_cast<int64_t>(bytes.size())};
    ASSERT_TRUE(blobs.Put(d, bytes).ok());
    // Uploaded long ago: no eviction grace protects it.
    std::filesystem::last_write_time(blobs.PathFor(d),
                                     std::filesystem::file_time_type::clock::now() - std::chrono::hours(1));
  };

  // Four unreferenced 3,000-byte uploads through replica B: 12,000 bytes
  // on disk, none of them in A's own count.
  for (char fill : {'p', 'q', 'r', 's'}) put_old(**blobs_b, std::string(3000, fill));
  EXPECT_EQ((*blobs_a)->total_bytes(), 0);
  auto evicted = a->EnforceStoreCap();
  ASSERT_TRUE(evicted.ok()) << evicted.status();
  EXPECT_EQ(evicted->blobs_removed, 1);
  EXPECT_EQ(on_disk(), 9000);

  // B still counts the blob A removed (12,000 > cap). Once B evicts (A
  // gone, its lock with it), it must see 9,000 and leave every blob.
  a.reset();
  store_a->reset();
  ASSERT_TRUE(*(*store_b)->HoldMaintenanceLock()) << "replica B evicts now";
  EXPECT_EQ((*blobs_b)->total_bytes(), 12000);
  evicted = b.EnforceStoreCap();
  ASSERT_TRUE(evicted.ok()) << evicted.status();
  EXPECT_EQ(evicted->blobs_removed, 0);
  EXPECT_EQ(on_disk(), 9000);
  EXPECT_EQ((*blobs_b)->total_bytes(), 9000);

  // A new upload through A's old view would not show in B's count until it
  // recounts: at most kSharedRecountMs (30 s) later.
  put_old(**blobs_a, std::string(3000, 't'));
  evicted = b.EnforceStoreCap();
  ASSERT_TRUE(evicted.ok());
  EXPECT_EQ(evicted->blobs_removed, 0) << "not recounted yet";
  now_ms_ += 30'000;
  evicted = b.EnforceStoreCap();
  ASSERT_TRUE(evicted.ok());
  EXPECT_EQ(evicted->blobs_removed, 1);
  EXPECT_LE(on_disk(), kCap);
}

}  // namespace
}  // namespace impostor::testing
