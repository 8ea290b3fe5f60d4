// Issue 18: cache hits answered from results kept in memory (ResultCache)
// must never serve a result the store no longer has: a purge, an eviction,
// a blob gone from disk or a missing input each make the very next hit a
// miss, and a new result is visible at once. Also the cache's own bound.
#include <atomic>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "server/scheduler/result_cache.h"
#include "tests/server/scheduler_fixture.h"

namespace impostor {
namespace {

class HotResultTest : public testing_support::SchedulerFixture {
 protected:
  // Rebuilds the scheduler with a store cap (bytes) and no eviction grace.
  void CapStore(int64_t max_bytes) {
    scheduler_ = std::make_unique<BakeScheduler>(
        jobs_.get(), blobs_.get(),
        SchedulerOptions{.store_max_bytes = max_bytes, .eviction_grace_ms = 0, .now_ms = [this] { return now_ms_; }});
  }

  // Bakes `content`, leased by the worker token `worker`; then serves the
  // result once so it is held in memory. Returns the request.
  v1::SubmitBakeRequest BakedAndHot(const std::string& content, const std::string& worker = "w1") {
    v1::SubmitBakeRequest request = Request(content);
    Submit(request, "ci-1");
    v1::LeaseJobRequest lease;
    lease.set_worker_id(worker);  // a worker id belongs to its token
    auto job = scheduler_->Lease(lease, std::chrono::steady_clock::now(), nullptr, worker);
    EXPECT_TRUE(job.ok() && job->has_value());
    EXPECT_TRUE(scheduler_->Complete(Result(**job)).ok());
    EXPECT_TRUE(LookupFinds(request));  // read once: now in memory
    EXPECT_TRUE(LookupFinds(request));  // and answered from it
    return request;
  }

  bool LookupFinds(const v1::SubmitBakeRequest& request) {
    auto r = scheduler_->Lookup(request);
    EXPECT_TRUE(r.ok()) << r.status();
    return r.ok() && r->found();
  }

  std::string KeyOf(const v1::SubmitBakeRequest& request) { return scheduler_->Lookup(request)->cache_key(); }

  // Every hit path says "no such result" for `request`.
  void ExpectMissEverywhere(const v1::SubmitBakeRequest& request, const std::string& key) {
    EXPECT_FALSE(LookupFinds(request));
    auto get = scheduler_->GetResult(key);
    EXPECT_EQ(get.status().code(), absl::StatusCode::kNotFound) << get.status();
    const v1::SubmitBakeResponse submit = Submit(request, "ci-2");
    EXPECT_FALSE(submit.cached());
    EXPECT_EQ(submit.job().state(), v1::JOB_STATE_QUEUED) << "a miss bakes again";
  }
};

TEST_F(HotResultTest, APurgedResultIsAMissAtOnce) {
  const v1::SubmitBakeRequest bad = BakedAndHot("tree", "bad-worker");
  const v1::SubmitBakeRequest good = BakedAndHot("rock", "good-worker");
  const std::string key = KeyOf(bad);
  ASSERT_TRUE(Submit(bad, "ci-1").cached());
  ASSERT_TRUE(scheduler_->GetResult(key).ok());
  auto purged = scheduler_->PurgeResultsBakedBy("bad-worker");
  ASSERT_TRUE(purged.ok()) << purged.status();
  ASSERT_EQ(purged->cache_keys.size(), 1u);
  ExpectMissEverywhere(bad, key);
  EXPECT_TRUE(LookupFinds(good)) << "another worker's result stays";
  EXPECT_TRUE(Submit(good, "ci-1").cached());
}

TEST_F(HotResultTest, AReBakeAfterAPurgeServesTheNewResult) {
  const v1::SubmitBakeRequest request = BakedAndHot("tree", "bad-worker");
  const std::string key = KeyOf(request);
  ASSERT_EQ(scheduler_->GetResult(key)->baked_by(), "bad-worker");
  ASSERT_TRUE(scheduler_->PurgeResultsBakedBy("bad-worker").ok());
  ExpectMissEverywhere(request, key);  // queues the re-bake
  v1::LeaseJobRequest lease;
  lease.set_worker_id("w2");
  auto job = scheduler_->Lease(lease, std::chrono::steady_clock::now(), nullptr, "good-worker");
  ASSERT_TRUE(job.ok() && job->has_value());
  ASSERT_TRUE(scheduler_->Complete(Result(**job)).ok());
  for (int i = 0; i < 2; ++i) {  // from the database, then from memory
    auto result = scheduler_->GetResult(key);
    ASSERT_TRUE(result.ok()) << result.status();
    EXPECT_EQ(result->baked_by(), "good-worker");
    const v1::SubmitBakeResponse hit = Submit(request, "ci-1");
    ASSERT_TRUE(hit.cached());
    EXPECT_EQ(hit.job().result().baked_by(), "good-worker");
  }
}

TEST_F(HotResultTest, AnEvictedResultIsAMissAtOnce) {
  CapStore(1);  // anything unpinned goes at the next pass
  const v1::SubmitBakeRequest request = BakedAndHot("tree");
  const std::string key = KeyOf(request);
  ASSERT_TRUE(scheduler_->GetResult(key).ok());
  auto stats = scheduler_->EnforceStoreCap();
  ASSERT_TRUE(stats.ok()) << stats.status();
  ASSERT_EQ(stats->results_removed, 1);
  // The evicted input is uploaded again, as a client would.
  Store("tree");
  ExpectMissEverywhere(request, key);
}

TEST_F(HotResultTest, APinnedResultSurvivesEvictionAndStaysAHit) {
  CapStore(1);
  const v1::SubmitBakeRequest request = BakedAndHot("tree");
  const std::string key = KeyOf(request);
  ASSERT_TRUE(scheduler_->PinResult(key, true).ok());
  ASSERT_TRUE(scheduler_->EnforceStoreCap().ok());
  EXPECT_TRUE(LookupFinds(request));
  EXPECT_TRUE(scheduler_->GetResult(key).ok());
}

TEST_F(HotResultTest, AResultBlobGoneFromDiskIsAMissAtOnce) {
  const v1::SubmitBakeRequest request = BakedAndHot("tree");
  const std::string key = KeyOf(request);
  auto result = scheduler_->GetResult(key);
  ASSERT_TRUE(result.ok());
  ASSERT_TRUE(blobs_->Remove(result->maps(0).digest().hash()).ok());
  ExpectMissEverywhere(request, key);
}

TEST_F(HotResultTest, AHitWithoutItsInputUploadedIsRefused) {
  const v1::SubmitBakeRequest request = BakedAndHot("tree");
  ASSERT_TRUE(Submit(request, "ci-1").cached());
  ASSERT_TRUE(blobs_->Remove(request.mesh().entry().digest().hash()).ok());
  auto submit = scheduler_->Submit(request, "ci-1");
  EXPECT_EQ(submit.status().code(), absl::StatusCode::kFailedPrecondition) << submit.status();
  EXPECT_NE(submit.status().message().find("mesh.entry"), std::string::npos) << submit.status();
}

TEST_F(HotResultTest, ANewResultIsVisibleAtOnce) {
  v1::SubmitBakeRequest request = Request("tree");
  EXPECT_FALSE(LookupFinds(request));
  request.set_request_id("first");
  const v1::SubmitBakeResponse queued = Submit(request, "ci-1");
  ASSERT_EQ(queued.job().state(), v1::JOB_STATE_QUEUED);
  ASSERT_TRUE(scheduler_->Complete(Result(Lease())).ok());
  EXPECT_TRUE(LookupFinds(request));
  EXPECT_TRUE(scheduler_->GetResult(queued.cache_key()).ok());
  // With the result in memory, a retried submit still gets its first job,
  // not a hit id; a fresh request id gets a hit.
  EXPECT_EQ(Submit(request, "ci-1").job_id(), queued.job_id());
  request.set_request_id("second");
  const v1::SubmitBakeResponse hit = Submit(request, "ci-1");
  EXPECT_TRUE(hit.cached());
  EXPECT_NE(hit.job_id(), queued.job_id());
  // A request id reused for another mesh is refused on the fast path too.
  v1::SubmitBakeRequest other = Request("rock");
  other.set_request_id("first");
  EXPECT_EQ(scheduler_->Submit(other, "ci-1").status().code(), absl::StatusCode::kInvalidArgument);
}

TEST_F(HotResultTest, HitsFromMemoryAreCountedAsUses) {
  const v1::SubmitBakeRequest request = BakedAndHot("tree");
  ASSERT_TRUE(scheduler_->FlushResultTouches().ok());
  now_ms_ += 5'000;
  ASSERT_TRUE(scheduler_->GetResult(KeyOf(request)).ok());
  auto peek = scheduler_->PeekResult(KeyOf(request));
  ASSERT_TRUE(peek.ok()) << peek.status();
  EXPECT_EQ(peek->last_used_ms, now_ms_) << "the use shows before the flush";
  auto flushed = scheduler_->FlushResultTouches();
  ASSERT_TRUE(flushed.ok());
  EXPECT_EQ(*flushed, 1);
}

// Readers hammer the hit paths on other threads while the result is
// purged: once PurgeResultsBakedBy has returned, no read that starts after
// it may find the result.
TEST_F(HotResultTest, NoReaderFindsAResultAfterItsPurgeReturned) {
  const v1::SubmitBakeRequest request = BakedAndHot("tree", "bad-worker");
  const std::string key = KeyOf(request);
  std::atomic<bool> purged{false};
  std::atomic<int> stale{0}, reads_before{0};
  std::vector<std::thread> readers;
  for (int t = 0; t < 4; ++t) {
    readers.emplace_back([&] {
      int reads_after = 0;
      while (reads_after < 50) {
        const bool after = purged.load();
        const bool found = scheduler_->GetResult(key).ok();
        if (!after) {
          ++reads_before;
          continue;
        }
        ++reads_after;
        if (found) ++stale;
      }
    });
  }
  while (reads_before.load() < 200) std::this_thread::yield();
  EXPECT_TRUE(scheduler_->PurgeResultsBakedBy("bad-worker").ok());
  purged = true;
  for (auto& t : readers) t.join();
  EXPECT_EQ(stale.load(), 0) << "a read that started after the purge found the purged result";
  EXPECT_FALSE(LookupFinds(request));
}

TEST(ResultCache, IsBoundedAndZeroCapacityKeepsNothing) {
  ResultCache cache(3);
  for (int i = 0; i < 10; ++i) {
    v1::Manifest m;
    m.set_cache_key("k" + std::to_string(i));
    cache.Fill(m);
    EXPECT_LE(cache.size(), 3u);
  }
  ASSERT_NE(cache.Find("k9"), nullptr) << "the newest entry is kept";
  EXPECT_EQ(cache.Find("k9")->cache_key(), "k9");
  cache.Erase("k9");
  EXPECT_EQ(cache.Find("k9"), nullptr);
  ResultCache off(0);
  v1::Manifest m;
  m.set_cache_key("k");
  off.Fill(m);
  EXPECT_EQ(off.Find("k"), nullptr);
  EXPECT_EQ(off.size(), 0u);
}

TEST(ResultCache, OnlyAStoreNoOtherServerWritesKeepsResultsInMemory) {
  const auto dir = std::filesystem::temp_directory_path() / ("hot_result_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  auto sqlite = JobStore::Open(dir / "jobs.sqlite3");
  ASSERT_TRUE(sqlite.ok()) << sqlite.status();
  EXPECT_FALSE((*sqlite)->SharedWithOtherServers());
  sqlite->reset();
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace impostor
