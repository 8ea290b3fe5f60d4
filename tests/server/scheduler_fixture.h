// A BakeScheduler over a real SQLite file and blob directory with a fake
// clock, for tests that drive Submit / Lease / Complete by hand (no worker,
// no sleeps: every Lease is an explicit call).
#ifndef IMPOSTOR_TESTS_SERVER_SCHEDULER_FIXTURE_H_
#define IMPOSTOR_TESTS_SERVER_SCHEDULER_FIXTURE_H_

#include <unistd.h>

#include <filesystem>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "common/util/sha256.h"
#include "server/scheduler/bake_scheduler.h"

namespace impostor::testing_support {

class SchedulerFixture : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("scheduler_fixture_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->test_suite_name() + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    Reopen();
  }
  void TearDown() override {
    scheduler_.reset();
    jobs_.reset();
    blobs_.reset();
    std::filesystem::remove_all(dir_);
  }
  // Simulates a server restart: everything rebuilt from disk.
  void Reopen() {
    scheduler_.reset();
    jobs_.reset();
    blobs_.reset();
    blobs_ = *BlobStore::Open(dir_ / "blobs");
    auto jobs = JobStore::Open(dir_ / "jobs.sqlite3");
    ASSERT_TRUE(jobs.ok()) << jobs.status();
    jobs_ = std::move(*jobs);
    scheduler_ = std::make_unique<BakeScheduler>(
        jobs_.get(), blobs_.get(),
        SchedulerOptions{.lease_timeout_ms = 30'000, .max_attempts = 3, .now_ms = [this] { return now_ms_; }});
  }

  v1::Digest Store(const std::string& bytes) {
    v1::Digest d;
    d.set_hash(Sha256Hex(bytes));
    d.set_size_bytes(static_cast<int64_t>(bytes.size()));
    EXPECT_TRUE(blobs_->Put({d.hash(), d.size_bytes()}, bytes).ok());
    return d;
  }

  // A request for a model whose bytes are `content` (distinct content =
  // distinct cache key).
  v1::SubmitBakeRequest Request(const std::string& content, int32_t priority = 0) {
    v1::SubmitBakeRequest r;
    r.mutable_mesh()->mutable_entry()->set_path("model.glb");
    *r.mutable_mesh()->mutable_entry()->mutable_digest() = Store(content);
    r.set_priority(priority);
    return r;
  }

  // Submits and advances the fake clock by 1 ms, so submission order is
  // creation order.
  v1::SubmitBakeResponse Submit(const v1::SubmitBakeRequest& request, const std::string& client) {
    auto r = scheduler_->Submit(request, client);
    EXPECT_TRUE(r.ok()) << r.status();
    ++now_ms_;
    return r.ok() ? *r : v1::SubmitBakeResponse();
  }

  // One explicit lease; empty job_id when nothing is queued.
  v1::LeasedJob Lease(const std::string& worker = "w1", const std::string& device = "") {
    v1::LeaseJobRequest r;
    r.set_worker_id(worker);
    r.set_device(device);
    auto job = scheduler_->Lease(r, std::chrono::steady_clock::now(), nullptr);
    EXPECT_TRUE(job.ok()) << job.status();
    return job.ok() && job->has_value() ? **job : v1::LeasedJob();
  }

  // A result for `job` whose quality block says `iou` and `psnr` (views 0 =
  // no quality measurement).
  v1::CompleteJobRequest Result(const v1::LeasedJob& job, uint32_t views = 16, float iou = 0.97f,
                                float psnr = 33.0f) {
    v1::CompleteJobRequest r;
    r.set_job_id(job.job_id());
    r.set_lease_id(job.lease_id());
    r.mutable_result()->set_cache_key(job.cache_key());
    *r.mutable_result()->mutable_manifest_json() = Store("{\"manifest\": true}");
    v1::MapFile* map = r.mutable_result()->add_maps();
    map->set_file("albedo_alpha.png");
    *map->mutable_digest() = Store("png " + job.cache_key());
    if (views > 0) {
      v1::AtlasQuality* q = r.mutable_result()->mutable_quality();
      q->set_views(views);
      q->set_silhouette_iou_mean(iou);
      q->set_albedo_psnr_shared_db_mean(psnr);
    }
    return r;
  }

  std::filesystem::path dir_;
  int64_t now_ms_ = 1'000'000;
  std::unique_ptr<BlobStore> blobs_;
  std::unique_ptr<JobStore> jobs_;
  std::unique_ptr<BakeScheduler> scheduler_;
};

}  // namespace impostor::testing_support

#endif  // IMPOSTOR_TESTS_SERVER_SCHEDULER_FIXTURE_H_
