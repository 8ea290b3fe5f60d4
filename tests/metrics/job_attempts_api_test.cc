// GET /api/v1/jobs/ID over a real HTTP frontend on a real port, in front of
// a scheduler driven by hand (fake clock): the job's attempt_history names
// each worker, its device and how its lease ended (issue 16).
#include <httplib.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "server/store/attempt_history.h"
#include "server/http/http_frontend.h"
#include "tests/server/scheduler_fixture.h"

namespace impostor {
namespace {

class JobAttemptsApiTest : public testing_support::SchedulerFixture {
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
  nlohmann::json GetJson(const std::string& path, int want_status = 200) {
    httplib::Client client("127.0.0.1", http_->port());
    auto res = client.Get(path.c_str());
    EXPECT_TRUE(res) << path;
    if (!res) return {};
    EXPECT_EQ(res->status, want_status) << path << ": " << res->body;
    return nlohmann::json::parse(res->body, nullptr, false);
  }
  std::unique_ptr<HttpFrontend> http_;
};

TEST_F(JobAttemptsApiTest, FirstWorkerDiesSecondSucceeds) {
  const std::string id = Submit(Request("mesh"), "artist").job_id();
  const int64_t t0 = now_ms_;
  Lease("host-a-1", "llvmpipe A");
  now_ms_ += 31'000;  // past the 30 s lease timeout
  ASSERT_TRUE(scheduler_->ExpireLeases().ok());
  const int64_t t1 = now_ms_;
  const v1::LeasedJob second = Lease("host-b-2", "llvmpipe B");
  now_ms_ += 700;
  ASSERT_TRUE(scheduler_->Complete(Result(second)).ok());

  const nlohmann::json job = GetJson("/api/v1/jobs/" + id);
  ASSERT_TRUE(job.is_object());
  EXPECT_EQ(job["state"], "succeeded");
  EXPECT_EQ(job["attempts"], 2);
  EXPECT_EQ(job["attempt_history_dropped"], 0);
  ASSERT_TRUE(job["attempt_history"].is_array()) << job.dump();
  ASSERT_EQ(job["attempt_history"].size(), 2u) << job.dump();
  const nlohmann::json& a = job["attempt_history"][0];
  EXPECT_EQ(a["attempt"], 1);
  EXPECT_EQ(a["worker_id"], "host-a-1");
  EXPECT_EQ(a["device"], "llvmpipe A");
  EXPECT_EQ(a["outcome"], "lease_expired");
  EXPECT_EQ(a["leased_ms"], t0);  // a JSON number, not a string
  EXPECT_EQ(a["ended_ms"], t1);
  const nlohmann::json& b = job["attempt_history"][1];
  EXPECT_EQ(b["attempt"], 2);
  EXPECT_EQ(b["worker_id"], "host-b-2");
  EXPECT_EQ(b["device"], "llvmpipe B");
  EXPECT_EQ(b["outcome"], "succeeded");
  EXPECT_EQ(b["leased_ms"], t1);
  EXPECT_EQ(b["ended_ms"], t1 + 700);
  EXPECT_EQ(b["message"], "");

  // The listing carries it too.
  const nlohmann::json page = GetJson("/api/v1/jobs?state=succeeded");
  ASSERT_EQ(page["jobs"].size(), 1u) << page.dump();
  EXPECT_EQ(page["jobs"][0]["attempt_history"].size(), 2u);
}

TEST_F(JobAttemptsApiTest, RunningLeaseShowsAsRunningWithNoEnd) {
  const std::string id = Submit(Request("mesh"), "artist").job_id();
  Lease("host-a-1", "gpu");
  const nlohmann::json job = GetJson("/api/v1/jobs/" + id);
  ASSERT_EQ(job["attempt_history"].size(), 1u) << job.dump();
  EXPECT_EQ(job["attempt_history"][0]["outcome"], "running");
  EXPECT_EQ(job["attempt_history"][0]["ended_ms"], 0);
}

TEST_F(JobAttemptsApiTest, UnknownJobIs404NotAnEmptyHistory) {
  const nlohmann::json error = GetJson("/api/v1/jobs/job-does-not-exist", 404);
  EXPECT_EQ(error["error"]["code"], 404) << error.dump();
}

}  // namespace
}  // namespace impostor
