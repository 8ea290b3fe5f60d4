// FarmMetrics fed by a real BakeScheduler (fake clock, explicit leases):
// every counter moves by exactly what the scheduler did, gauges follow the
// job table, and worker labels stay bounded. Also the scheduler's read-only
// views the HTTP API serves (listing, paging, workers).
#include "server/metrics/farm_metrics.h"

#include <gtest/gtest.h>

#include "server/http/json_api.h"
#include "tests/metrics/exposition_parser.h"
#include "tests/server/scheduler_fixture.h"

namespace impostor {
namespace {

using testing::Exposition;
using testing::ParseExposition;

class FarmMetricsTest : public testing_support::SchedulerFixture {
 protected:
  void SetUp() override {
    SchedulerFixture::SetUp();
    metrics_ = std::make_unique<FarmMetrics>(scheduler_.get(), blobs_.get());
    scheduler_->SetObserver(metrics_.get());
  }
  void TearDown() override {
    scheduler_->SetObserver(nullptr);
    metrics_.reset();
    SchedulerFixture::TearDown();
  }
  Exposition Scrape() {
    const std::string text = metrics_->Scrape();
    auto parsed = ParseExposition(text);
    EXPECT_TRUE(parsed.ok()) << parsed.status() << "\n" << text;
    return parsed.ok() ? *parsed : Exposition();
  }
  std::unique_ptr<FarmMetrics> metrics_;
};

TEST_F(FarmMetricsTest, WorkersAreCountedByTheDeviceKindTheyReportUnderAFixedLabelSet) {
  auto lease = [&](const std::string& worker, const char* kind) {
    v1::LeaseJobRequest r;
    r.set_worker_id(worker);
    if (kind != nullptr) r.mutable_capabilities()->set_device_kind(kind);
    ASSERT_TRUE(scheduler_->Lease(r, std::chrono::steady_clock::now(), nullptr).ok());
  };
  lease("gpu-1", "discrete");
  lease("gpu-2", "discrete");
  lease("laptop", "cpu");
  lease("odd", "quantum");  // not a kind we label: counted as other
  lease("old", nullptr);    // reports nothing
  Exposition e = Scrape();
  EXPECT_EQ(e.Value("impostor_workers_by_device_kind", {{"device_kind", "discrete"}}), 2);
  EXPECT_EQ(e.Value("impostor_workers_by_device_kind", {{"device_kind", "cpu"}}), 1);
  EXPECT_EQ(e.Value("impostor_workers_by_device_kind", {{"device_kind", "other"}}), 1);
  EXPECT_EQ(e.Value("impostor_workers_by_device_kind", {{"device_kind", "unreported"}}), 1);
  EXPECT_EQ(e.Value("impostor_workers_by_device_kind", {{"device_kind", "integrated"}}), 0);
  EXPECT_EQ(e.Sum("impostor_workers_by_device_kind"), 5);
  // And the JSON API shows what each reported.
  auto workers = scheduler_->Workers();
  ASSERT_TRUE(workers.ok());
  const nlohmann::json json = WorkersJson(*workers, *metrics_);
  int reported = 0;
  for (const auto& w : json["workers"]) {
    if (w["worker_id"] == "old") {
      EXPECT_TRUE(w["capabilities"].is_null());
    } else {
      EXPECT_TRUE(w["capabilities"].is_object()) << w.dump();
      ++reported;
    }
    if (w["worker_id"] == "laptop") EXPECT_EQ(w["capabilities"]["device_kind"], "cpu");
  }
  EXPECT_EQ(reported, 4);
}

TEST_F(FarmMetricsTest, BakeThenCacheHitMoveCountersByExactlyWhatHappened) {
  const auto request = Request("mesh one");
  Submit(request, "alice");
  Exposition queued = Scrape();
  EXPECT_EQ(queued.Value("impostor_submits_total", {{"product", "atlas"}, {"outcome", "queued"}}), 1);
  EXPECT_EQ(queued.Value("impostor_cache_misses_total", {{"product", "atlas"}}), 1);
  EXPECT_EQ(queued.Value("impostor_cache_hits_total", {{"product", "atlas"}}), 0);
  EXPECT_EQ(queued.Value("impostor_jobs", {{"state", "queued"}}), 1);
  EXPECT_EQ(queued.Value("impostor_jobs", {{"state", "running"}}), 0);

  now_ms_ += 2500;  // 2.5 s in the queue
  const v1::LeasedJob job = Lease("worker-a");
  ASSERT_FALSE(job.job_id().empty());
  Exposition running = Scrape();
  EXPECT_EQ(running.Value("impostor_jobs", {{"state", "running"}}), 1);
  EXPECT_EQ(running.Value("impostor_workers", {{"state", "busy"}}), 1);
  EXPECT_EQ(running.Value("impostor_lease_latency_seconds_count", {{"product", "atlas"}}), 1);
  EXPECT_DOUBLE_EQ(running.Value("impostor_lease_latency_seconds_sum", {{"product", "atlas"}}), 2.501);
  EXPECT_EQ(running.Value("impostor_lease_latency_seconds_bucket", {{"product", "atlas"}, {"le", "2"}}), 0);
  EXPECT_EQ(running.Value("impostor_lease_latency_seconds_bucket", {{"product", "atlas"}, {"le", "5"}}), 1);

  v1::CompleteJobRequest result = Result(job);
  result.mutable_result()->mutable_timings()->set_total_seconds(12.5);
  result.mutable_result()->mutable_timings()->set_render_seconds(7);
  ASSERT_TRUE(scheduler_->Complete(result).ok());
  Submit(request, "bob");  // the same bake again: a cache hit

  Exposition done = Scrape();
  EXPECT_EQ(done.Value("impostor_submits_total", {{"product", "atlas"}, {"outcome", "queued"}}), 1);
  EXPECT_EQ(done.Value("impostor_submits_total", {{"product", "atlas"}, {"outcome", "cache_hit"}}), 1);
  EXPECT_EQ(done.Value("impostor_cache_hits_total", {{"product", "atlas"}}), 1);
  EXPECT_EQ(done.Value("impostor_cache_misses_total", {{"product", "atlas"}}), 1);
  EXPECT_EQ(done.Value("impostor_jobs_completed_total", {{"product", "atlas"}}), 1);
  EXPECT_EQ(done.Value("impostor_worker_jobs_completed_total", {{"worker", "worker-a"}}), 1);
  EXPECT_EQ(done.Value("impostor_bake_seconds_count", {{"product", "atlas"}}), 1);
  EXPECT_DOUBLE_EQ(done.Value("impostor_bake_seconds_sum", {{"product", "atlas"}}), 12.5);
  EXPECT_EQ(done.Value("impostor_bake_seconds_bucket", {{"product", "atlas"}, {"le", "10"}}), 0);
  EXPECT_EQ(done.Value("impostor_bake_seconds_bucket", {{"product", "atlas"}, {"le", "20"}}), 1);
  EXPECT_DOUBLE_EQ(done.Value("impostor_bake_stage_seconds_sum", {{"product", "atlas"}, {"stage", "render"}}), 7);
  // The job rows: the bake's. A cache hit has no row (issue 18: it writes
  // nothing that needs a sync); impostor_submits_total counts it above.
  EXPECT_EQ(done.Value("impostor_jobs", {{"state", "succeeded"}}), 1);
  EXPECT_EQ(done.Value("impostor_jobs", {{"state", "running"}}), 0);
  EXPECT_EQ(done.Value("impostor_workers", {{"state", "busy"}}), 0);
  EXPECT_EQ(done.Value("impostor_workers", {{"state", "idle"}}), 1);
  EXPECT_EQ(done.Value("impostor_blob_store_bytes"), static_cast<double>(blobs_->total_bytes()));
  const FarmMetrics::Totals totals = metrics_->totals();
  EXPECT_EQ(totals.cache_hits, 1);
  EXPECT_EQ(totals.cache_misses, 1);
  EXPECT_EQ(totals.jobs_completed, 1);
}

TEST_F(FarmMetricsTest, FailuresLostLeasesAndSharedBakes) {
  const auto request = Request("mesh two");
  Submit(request, "alice");
  Submit(request, "bob");  // shares the queued bake
  v1::LeasedJob job = Lease("worker-a");
  v1::FailJobRequest fail;
  fail.set_job_id(job.job_id());
  fail.set_lease_id(job.lease_id());
  fail.set_retryable(true);
  fail.mutable_error()->set_code(14);
  fail.mutable_error()->set_message("device lost");
  ASSERT_TRUE(scheduler_->Fail(fail).ok());
  job = Lease("worker-b");
  ASSERT_FALSE(job.job_id().empty());
  now_ms_ += 31'000;  // past the 30 s lease timeout
  ASSERT_TRUE(scheduler_->ExpireLeases().ok());

  Exposition e = Scrape();
  EXPECT_EQ(e.Value("impostor_submits_total", {{"product", "atlas"}, {"outcome", "shared_bake"}}), 1);
  EXPECT_EQ(e.Value("impostor_cache_misses_total", {{"product", "atlas"}}), 2);
  EXPECT_EQ(e.Value("impostor_jobs_failed_total", {{"product", "atlas"}, {"retried", "true"}}), 1);
  EXPECT_EQ(e.Value("impostor_leases_lost_total", {{"product", "atlas"}}), 1);
  EXPECT_EQ(e.Value("impostor_leases_total", {{"product", "atlas"}}), 2);
  // The latency histogram counts first leases only.
  EXPECT_EQ(e.Value("impostor_lease_latency_seconds_count", {{"product", "atlas"}}), 1);
  EXPECT_EQ(e.Value("impostor_worker_jobs_failed_total", {{"worker", "worker-a"}}), 1);
  EXPECT_EQ(e.Value("impostor_worker_jobs_failed_total", {{"worker", "worker-b"}}), 1);
  EXPECT_EQ(e.Value("impostor_jobs", {{"state", "queued"}}), 2);  // the leader and its follower
  EXPECT_EQ(e.Value("impostor_workers", {{"state", "offline"}}), 2);
}

TEST_F(FarmMetricsTest, RpcsByMethodAndCodeWithUnknownMethodsFolded) {
  metrics_->OnRpc("/impostor.v1.BakeService/SubmitBake", 0);
  metrics_->OnRpc("/impostor.v1.BakeService/SubmitBake", 0);
  metrics_->OnRpc("/impostor.v1.BakeService/SubmitBake", 3);
  metrics_->OnRpc("/made.up.Service/ClientChosen" + std::string(100, 'x'), 12);
  Exposition e = Scrape();
  EXPECT_EQ(e.Value("impostor_rpcs_total", {{"method", "/impostor.v1.BakeService/SubmitBake"}, {"code", "OK"}}), 2);
  EXPECT_EQ(e.Value("impostor_rpcs_total",
                    {{"method", "/impostor.v1.BakeService/SubmitBake"}, {"code", "INVALID_ARGUMENT"}}), 1);
  EXPECT_EQ(e.Value("impostor_rpcs_total", {{"method", "other"}, {"code", "UNIMPLEMENTED"}}), 1);
}

TEST_F(FarmMetricsTest, WorkerLabelsAreBounded) {
  const size_t workers = FarmMetrics::kMaxWorkerLabels + 10;
  for (size_t i = 0; i < workers; ++i) metrics_->OnFail("w" + std::to_string(i), v1::PRODUCT_ATLAS, false);
  Exposition e = Scrape();
  size_t series = 0;
  for (const auto& [key, value] : e.samples) series += key.rfind("impostor_worker_jobs_failed_total{", 0) == 0;
  EXPECT_EQ(series, FarmMetrics::kMaxWorkerLabels + 1);
  EXPECT_EQ(e.Value("impostor_worker_jobs_failed_total", {{"worker", "_other"}}), 10);
  EXPECT_EQ(e.Sum("impostor_worker_jobs_failed_total"), static_cast<double>(workers));
}

// The certificate's expiry means nothing without TLS: no series at all, so
// an alert on "expires within a week" cannot fire on a plaintext server; with
// TLS it is the expiry, 0 while the files are unusable (main.cc sets it).
TEST_F(FarmMetricsTest, TlsCertExpiryIsAbsentUntilTlsSetsIt) {
  EXPECT_FALSE(Scrape().Has("impostor_tls_cert_expiry_timestamp_seconds"));
  EXPECT_EQ(metrics_->Scrape().find("impostor_tls_cert_expiry_timestamp_seconds"), std::string::npos)
      << "no HELP or TYPE line either";
  metrics_->SetTlsCertExpiry(1'900'000'000);
  EXPECT_EQ(Scrape().Value("impostor_tls_cert_expiry_timestamp_seconds"), 1'900'000'000);
  metrics_->SetTlsCertExpiry(0);
  Exposition e = Scrape();
  ASSERT_TRUE(e.Has("impostor_tls_cert_expiry_timestamp_seconds"));
  EXPECT_EQ(e.Value("impostor_tls_cert_expiry_timestamp_seconds"), 0);
}

TEST_F(FarmMetricsTest, ListJobsPagesNewestFirstWithStateFilter) {
  std::vector<std::string> ids;
  for (int i = 0; i < 5; ++i) ids.push_back(Submit(Request("mesh " + std::to_string(i)), "alice").job_id());
  const v1::LeasedJob leased = Lease("worker-a");  // the oldest: ids[0]
  auto page1 = scheduler_->ListJobs(v1::JOB_STATE_UNSPECIFIED, 2, std::nullopt);
  ASSERT_TRUE(page1.ok()) << page1.status();
  ASSERT_EQ(page1->size(), 2u);
  EXPECT_EQ((*page1)[0].job.job_id(), ids[4]);
  EXPECT_EQ((*page1)[1].job.job_id(), ids[3]);
  EXPECT_EQ((*page1)[0].client_id, "alice");
  const nlohmann::json json = JobsPageJson(*page1, 2, JobViewer{.admin = true});
  ASSERT_TRUE(json.contains("next_page_token"));
  EXPECT_TRUE(json["jobs"][0]["mesh"]["entry"].contains("digest")) << json.dump();
  // Anyone but the submitter or an admin: the mesh's paths, not its digests
  // (a digest named in one's own SubmitBake would read the blob back).
  for (const JobViewer& stranger : {JobViewer{.name = "mallory"}, JobViewer{}}) {
    const nlohmann::json hidden = JobsPageJson(*page1, 2, stranger);
    EXPECT_FALSE(hidden["jobs"][0]["mesh"]["entry"].contains("digest")) << hidden.dump();
    EXPECT_EQ(hidden["jobs"][0]["mesh"]["entry"]["path"], json["jobs"][0]["mesh"]["entry"]["path"]);
    EXPECT_EQ(hidden["jobs"][0]["mesh"]["digests_hidden"], true);
  }
  auto page2 = scheduler_->ListJobs(v1::JOB_STATE_UNSPECIFIED, 10,
                                    JobStore::JobCursor{(*page1)[1].job.created_ms(), (*page1)[1].job.job_id()});
  ASSERT_TRUE(page2.ok());
  ASSERT_EQ(page2->size(), 3u);
  EXPECT_EQ((*page2)[2].job.job_id(), ids[0]);
  EXPECT_FALSE(JobsPageJson(*page2, 10, JobViewer{.admin = true}).contains("next_page_token"));
  auto running = scheduler_->ListJobs(v1::JOB_STATE_RUNNING, 10, std::nullopt);
  ASSERT_TRUE(running.ok());
  ASSERT_EQ(running->size(), 1u);
  EXPECT_EQ((*running)[0].job.job_id(), leased.job_id());
  EXPECT_EQ((*running)[0].job.worker_id(), "worker-a");
  auto workers = scheduler_->Workers();
  ASSERT_TRUE(workers.ok());
  ASSERT_EQ(workers->size(), 1u);
  EXPECT_EQ((*workers)[0].state, "busy");
  EXPECT_EQ((*workers)[0].job_ids, std::vector<std::string>{leased.job_id()});
}

}  // namespace
}  // namespace impostor
