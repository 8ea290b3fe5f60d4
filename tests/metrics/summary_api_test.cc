// GET /api/v1/summary and /api/v1/workers over a real HTTP frontend in
// front of a scheduler driven by hand: counts are JSON integers (301, not
// 301.0), as the jobs-by-state counts are, though FarmMetrics keeps them as
// Prometheus counters (doubles); only ratios are floating point.
#include <httplib.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "server/http/http_frontend.h"
#include "tests/server/scheduler_fixture.h"

namespace impostor {
namespace {

class SummaryApiTest : public testing_support::SchedulerFixture {
 protected:
  void SetUp() override {
    SchedulerFixture::SetUp();
    auto http = HttpFrontend::Start(scheduler_.get(), blobs_.get(), {.listen = {"127.0.0.1", 0}, .static_dir = {}});
    ASSERT_TRUE(http.ok()) << http.status();
    http_ = std::move(*http);
  }
  void TearDown() override {
    http_.reset();
    SchedulerFixture::TearDown();
  }
  nlohmann::json GetJson(const std::string& path) {
    httplib::Client client("127.0.0.1", http_->port());
    auto res = client.Get(path.c_str());
    EXPECT_TRUE(res) << path;
    if (!res) return {};
    EXPECT_EQ(res->status, 200) << path << ": " << res->body;
    return nlohmann::json::parse(res->body, nullptr, false);
  }
  std::unique_ptr<HttpFrontend> http_;
};

TEST_F(SummaryApiTest, CountsAreIntegers) {
  // One bake completed (a miss), the same mesh asked again (a hit), one failed.
  const v1::SubmitBakeRequest request = Request("mesh");
  Submit(request, "artist");
  const v1::LeasedJob done = Lease("w1");
  ASSERT_TRUE(scheduler_->Complete(Result(done)).ok());
  Submit(request, "artist");
  Submit(Request("other mesh"), "artist");
  const v1::LeasedJob failing = Lease("w1");
  v1::FailJobRequest fail;
  fail.set_job_id(failing.job_id());
  fail.set_lease_id(failing.lease_id());
  fail.set_retryable(false);
  fail.mutable_error()->set_code(3);
  fail.mutable_error()->set_message("bad mesh");
  ASSERT_TRUE(scheduler_->Fail(fail).ok());

  const nlohmann::json summary = GetJson("/api/v1/summary");
  ASSERT_TRUE(summary.is_object()) << summary.dump();
  const struct {
    const char* field;
    int64_t want;
  } kCounts[] = {{"cache_hits", 1}, {"cache_misses", 2}, {"jobs_completed", 1}, {"jobs_failed", 1}};
  for (const auto& c : kCounts) {
    ASSERT_TRUE(summary.contains(c.field)) << c.field << ": " << summary.dump();
    EXPECT_TRUE(summary[c.field].is_number_integer()) << c.field << " is " << summary[c.field].dump();
    EXPECT_EQ(summary[c.field], c.want) << c.field;
  }
  EXPECT_TRUE(summary["jobs"]["succeeded"].is_number_integer()) << summary.dump();
  EXPECT_TRUE(summary["cache_hit_ratio"].is_number_float()) << summary.dump();
  EXPECT_NEAR(summary["cache_hit_ratio"].get<double>(), 1.0 / 3, 1e-9);

  const nlohmann::json workers = GetJson("/api/v1/workers");
  ASSERT_TRUE(workers["workers"].is_array()) << workers.dump();
  ASSERT_EQ(workers["workers"].size(), 1u) << workers.dump();
  const nlohmann::json& w = workers["workers"][0];
  for (const char* field : {"jobs_completed", "jobs_failed"}) {
    EXPECT_TRUE(w[field].is_number_integer()) << field << " is " << w[field].dump();
    EXPECT_EQ(w[field], 1) << field;
  }
}

}  // namespace
}  // namespace impostor
