#include <filesystem>

#include <gtest/gtest.h>

#include "common/util/sha256.h"
#include "server/scheduler/bake_scheduler.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

// Eviction under a store size cap, with a fake clock and real files.
class StoreCapTest : public testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("store_cap_test_" + std::to_string(::getpid()) + "_" +
                                        testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    blobs_ = *BlobStore::Open(dir_ / "blobs");
    jobs_ = *JobStore::Open(dir_ / "jobs.sqlite3");
    scheduler_ = std::make_unique<BakeScheduler>(
        jobs_.get(), blobs_.get(),
        SchedulerOptions{.store_max_bytes = 10'000, .eviction_grace_ms = 0, .now_ms = [this] { return now_ms_; }});
  }
  void TearDown() override { fs::remove_all(dir_); }

  v1::Digest Store(const std::string& bytes) {
    v1::Digest d;
    d.set_hash(Sha256Hex(bytes));
    d.set_size_bytes(static_cast<int64_t>(bytes.size()));
    EXPECT_TRUE(blobs_->Put({d.hash(), d.size_bytes()}, bytes).ok());
    return d;
  }
  bool Has(const v1::Digest& d) { return blobs_->Contains({d.hash(), d.size_bytes()}); }

  // Submits and completes a bake whose input and output are `size` bytes each.
  std::string Bake(char fill, size_t size, v1::Digest* input, v1::Digest* output) {
    v1::SubmitBakeRequest r;
    r.mutable_mesh()->mutable_entry()->set_path("m.glb");
    *input = Store(std::string(size, fill));
    *r.mutable_mesh()->mutable_entry()->mutable_digest() = *input;
    auto s = scheduler_->Submit(r);
    EXPECT_TRUE(s.ok()) << s.status();
    v1::LeaseJobRequest l;
    l.set_worker_id("w");
    auto job = **scheduler_->Lease(l, std::chrono::steady_clock::now(), nullptr);
    v1::CompleteJobRequest c;
    c.set_job_id(job.job_id());
    c.set_lease_id(job.lease_id());
    c.mutable_result()->set_cache_key(job.cache_key());
    *c.mutable_result()->mutable_manifest_json() = Store(std::string("{}") + fill);
    v1::MapFile* map = c.mutable_result()->add_maps();
    *output = Store(std::string(size, static_cast<char>(fill + 1)));
    *map->mutable_digest() = *output;
    EXPECT_TRUE(scheduler_->Complete(c).ok());
    ++now_ms_;
    return job.cache_key();
  }

  fs::path dir_;
  int64_t now_ms_ = 1'000'000;
  std::unique_ptr<BlobStore> blobs_;
  std::unique_ptr<JobStore> jobs_;
  std::unique_ptr<BakeScheduler> scheduler_;
};

TEST_F(StoreCapTest, EvictsUnreferencedInputsFirstThenLeastRecentlyUsedResults) {
  v1::Digest in_a, out_a, in_b, out_b, in_c, out_c;
  const std::string a = Bake('a', 3000, &in_a, &out_a);
  const std::string b = Bake('c', 3000, &in_b, &out_b);
  ASSERT_TRUE(scheduler_->GetResult(a).ok());  // a is now more recently used than b
  ++now_ms_;
  const std::string c = Bake('e', 3000, &in_c, &out_c);
  EXPECT_GT(blobs_->total_bytes(), 10'000);
  auto stats = scheduler_->EnforceStoreCap();
  ASSERT_TRUE(stats.ok()) << stats.status();
  EXPECT_LE(blobs_->total_bytes(), 10'000);
  // Finished jobs' inputs go before any result.
  EXPECT_FALSE(Has(in_a));
  EXPECT_FALSE(Has(in_b));
  EXPECT_TRUE(Has(out_a) && Has(out_b) && Has(out_c)) << "three 3 kB results fit once inputs are gone";
  EXPECT_EQ(stats->results_removed, 0);

  // Tighten the cap: the least recently used result (b) goes first.
  scheduler_ = std::make_unique<BakeScheduler>(
      jobs_.get(), blobs_.get(),
      SchedulerOptions{.store_max_bytes = 7'000, .eviction_grace_ms = 0, .now_ms = [this] { return now_ms_; }});
  ASSERT_TRUE(scheduler_->EnforceStoreCap().ok());
  EXPECT_FALSE(Has(out_b));
  EXPECT_EQ(scheduler_->GetResult(b).status().code(), absl::StatusCode::kNotFound);
  EXPECT_TRUE(scheduler_->GetResult(a).ok());
  EXPECT_TRUE(scheduler_->GetResult(c).ok());
}

TEST_F(StoreCapTest, PinnedResultsAndPendingInputsAreNeverEvicted) {
  v1::Digest in_a, out_a, in_b, out_b;
  const std::string a = Bake('a', 4000, &in_a, &out_a);
  ASSERT_TRUE(scheduler_->PinResult(a, true).ok());
  const std::string b = Bake('c', 4000, &in_b, &out_b);
  // A queued job's input must survive whatever happens.
  v1::SubmitBakeRequest queued;
  queued.mutable_mesh()->mutable_entry()->set_path("q.glb");
  const v1::Digest q = Store(std::string(4000, 'q'));
  *queued.mutable_mesh()->mutable_entry()->mutable_digest() = q;
  ASSERT_TRUE(scheduler_->Submit(queued).ok());
  ASSERT_TRUE(scheduler_->EnforceStoreCap().ok());
  EXPECT_TRUE(Has(q)) << "input of a queued job";
  EXPECT_TRUE(Has(out_a)) << "pinned result";
  EXPECT_FALSE(Has(out_b)) << "the unpinned result made room";
  EXPECT_EQ(scheduler_->PinResult(std::string(64, '0'), true).code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(scheduler_->PinResult("nope", true).code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace impostor
