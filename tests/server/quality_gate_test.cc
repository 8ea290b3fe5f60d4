// The quality gate: the pure check (common/quality_gate) and how the
// scheduler applies it to each requester, on fresh bakes, shared bakes and
// cache hits.
#include "common/request/quality_gate.h"

#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "tests/server/scheduler_fixture.h"

namespace impostor {
namespace {

v1::QualityGate Gate(std::optional<float> iou, std::optional<float> psnr) {
  v1::QualityGate g;
  if (iou) g.set_min_iou(*iou);
  if (psnr) g.set_min_psnr_db(*psnr);
  return g;
}

v1::Manifest Measured(uint32_t views, float iou, float psnr) {
  v1::Manifest m;
  if (views > 0) {
    m.mutable_quality()->set_views(views);
    m.mutable_quality()->set_silhouette_iou_mean(iou);
    m.mutable_quality()->set_albedo_psnr_shared_db_mean(psnr);
  }
  return m;
}

TEST(CheckQualityGate, Table) {
  struct Case {
    const char* name;
    v1::QualityGate gate;
    v1::Manifest result;
    absl::StatusCode code;
    std::string message;  // exact, when not OK
  };
  const Case cases[] = {
      {"no gate, no measurement", Gate({}, {}), Measured(0, 0, 0), absl::StatusCode::kOk, ""},
      {"no gate, poor result", Gate({}, {}), Measured(16, 0.1f, 5), absl::StatusCode::kOk, ""},
      {"both met", Gate(0.95f, 30), Measured(16, 0.97f, 33), absl::StatusCode::kOk, ""},
      {"exactly at the thresholds", Gate(0.5f, 30), Measured(16, 0.5f, 30), absl::StatusCode::kOk, ""},
      {"iou short, psnr met", Gate(0.95f, 30), Measured(16, 0.912f, 31.2f), absl::StatusCode::kFailedPrecondition,
       "quality gate: silhouette IoU 0.912 < min_iou 0.95; albedo PSNR 31.2 dB >= min_psnr_db 30"},
      {"psnr short only", Gate({}, 35), Measured(16, 0.99f, 31.24f), absl::StatusCode::kFailedPrecondition,
       "quality gate: albedo PSNR 31.2 dB < min_psnr_db 35"},
      {"both short", Gate(0.9f, 40), Measured(8, 0.85f, 20), absl::StatusCode::kFailedPrecondition,
       "quality gate: silhouette IoU 0.850 < min_iou 0.9; albedo PSNR 20.0 dB < min_psnr_db 40"},
      {"no measurement", Gate(0.5f, {}), Measured(0, 0, 0), absl::StatusCode::kFailedPrecondition,
       "quality gate: the result has no quality measurement"},
  };
  for (const Case& c : cases) {
    const absl::Status s = CheckQualityGate(c.gate, c.result);
    EXPECT_EQ(s.code(), c.code) << c.name << ": " << s;
    if (!s.ok()) EXPECT_EQ(s.message(), c.message) << c.name;
  }
}

TEST(ValidateQualityGate, RangesAreChecked) {
  struct Case {
    v1::QualityGate gate;
    std::string error;  // empty = valid
  } cases[] = {
      {Gate({}, {}), ""},
      {Gate(0, 0), ""},
      {Gate(1, 100), ""},
      {Gate(1.5f, {}), "gate.min_iou: 1.5 is out of range 0..1"},
      {Gate(-0.1f, {}), "gate.min_iou: -0.1 is out of range 0..1"},
      {Gate(std::nanf(""), {}), "gate.min_iou: nan is out of range 0..1"},
      {Gate({}, 120), "gate.min_psnr_db: 120 is out of range 0..100"},
      {Gate({}, -1), "gate.min_psnr_db: -1 is out of range 0..100"},
  };
  for (const Case& c : cases) {
    const absl::Status s = ValidateQualityGate(c.gate);
    if (c.error.empty()) {
      EXPECT_TRUE(s.ok()) << s;
    } else {
      EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << c.error;
      EXPECT_EQ(s.message(), c.error);
    }
  }
}

class GatedSchedulerTest : public testing_support::SchedulerFixture {
 protected:
  v1::SubmitBakeRequest Gated(const std::string& content, std::optional<float> iou, std::optional<float> psnr) {
    v1::SubmitBakeRequest r = Request(content);
    *r.mutable_gate() = Gate(iou, psnr);
    return r;
  }
  v1::Job Get(const std::string& job_id) {
    auto j = scheduler_->GetJob(job_id);
    EXPECT_TRUE(j.ok()) << j.status();
    return j.ok() ? *j : v1::Job();
  }
};

TEST_F(GatedSchedulerTest, EachRequesterOfASharedBakeIsJudgedByItsOwnGate) {
  auto strict = Submit(Gated("tree", 0.95f, 30), "ci");         // leader
  auto lenient = Submit(Gated("tree", 0.8f, {}), "artist");     // follower, passes
  auto ungated = Submit(Request("tree"), "bob");                 // follower, no gate
  auto strict_follower = Submit(Gated("tree", {}, 40), "eve");  // follower, fails on PSNR
  v1::LeasedJob job = Lease();
  ASSERT_EQ(job.job_id(), strict.job_id());
  EXPECT_TRUE(Lease().job_id().empty()) << "one bake for all four; the gate is not part of the cache key";
  ASSERT_TRUE(scheduler_->Complete(Result(job, 16, 0.912f, 31.2f)).ok());

  const v1::Job failed = Get(strict.job_id());
  EXPECT_EQ(failed.state(), v1::JOB_STATE_FAILED);
  EXPECT_EQ(failed.error().code(), 9);
  EXPECT_EQ(failed.error().message(),
            "quality gate: silhouette IoU 0.912 < min_iou 0.95; albedo PSNR 31.2 dB >= min_psnr_db 30");
  EXPECT_EQ(failed.result().maps(0).file(), "albedo_alpha.png") << "the result stays attached for inspection";
  EXPECT_EQ(failed.result().cache_key(), strict.cache_key());

  EXPECT_EQ(Get(lenient.job_id()).state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(Get(ungated.job_id()).state(), v1::JOB_STATE_SUCCEEDED);
  const v1::Job follower = Get(strict_follower.job_id());
  EXPECT_EQ(follower.state(), v1::JOB_STATE_FAILED);
  EXPECT_EQ(follower.error().message(), "quality gate: albedo PSNR 31.2 dB < min_psnr_db 40");
  EXPECT_TRUE(follower.has_result());

  // The bake itself is cached: an ungated request is a hit.
  auto hit = Submit(Request("tree"), "ci");
  EXPECT_TRUE(hit.cached());
  EXPECT_EQ(hit.job().state(), v1::JOB_STATE_SUCCEEDED);
}

TEST_F(GatedSchedulerTest, PassingGateSucceeds) {
  auto r = Submit(Gated("rock", 0.9f, 25), "ci");
  ASSERT_TRUE(scheduler_->Complete(Result(Lease(), 16, 0.93f, 28)).ok());
  const v1::Job j = Get(r.job_id());
  EXPECT_EQ(j.state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_FALSE(j.has_error());
}

TEST_F(GatedSchedulerTest, ResultWithoutMeasurementFailsAGatedRequest) {
  auto r = Submit(Gated("rock", 0.5f, {}), "ci");
  ASSERT_TRUE(scheduler_->Complete(Result(Lease(), /*views=*/0)).ok());
  const v1::Job j = Get(r.job_id());
  EXPECT_EQ(j.state(), v1::JOB_STATE_FAILED);
  EXPECT_EQ(j.error().message(), "quality gate: the result has no quality measurement");
  EXPECT_TRUE(j.has_result());
}

TEST_F(GatedSchedulerTest, CacheHitIsGatedToo) {
  Submit(Request("bush"), "ci");
  ASSERT_TRUE(scheduler_->Complete(Result(Lease(), 16, 0.88f, 29)).ok());

  auto failing = Submit(Gated("bush", 0.9f, {}), "ci");
  EXPECT_TRUE(failing.cached());
  EXPECT_EQ(failing.job().state(), v1::JOB_STATE_FAILED);
  EXPECT_EQ(failing.job().error().code(), 9);
  EXPECT_EQ(failing.job().error().message(), "quality gate: silhouette IoU 0.880 < min_iou 0.9");
  EXPECT_EQ(failing.job().result().maps(0).file(), "albedo_alpha.png");
  const v1::Job again = Get(failing.job_id());
  EXPECT_EQ(again.state(), v1::JOB_STATE_FAILED);
  EXPECT_TRUE(again.has_result()) << "GetJob attaches the result of a gate failure too";

  auto passing = Submit(Gated("bush", 0.85f, 28), "ci");
  EXPECT_TRUE(passing.cached());
  EXPECT_EQ(passing.job().state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_TRUE(Lease().job_id().empty()) << "gated cache hits never reach the queue";
}

TEST_F(GatedSchedulerTest, GateOutOfRangeIsInvalidArgument) {
  auto r = scheduler_->Submit(Gated("rock", 1.2f, {}), "ci");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(r.status().message(), "gate.min_iou: 1.2 is out of range 0..1");
  r = scheduler_->Submit(Gated("rock", {}, 101), "ci");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().message(), "gate.min_psnr_db: 101 is out of range 0..100");
}

// A gate on a bake that measures nothing it judges could never pass: it is
// refused at submit, before anything is baked or queued.
TEST_F(GatedSchedulerTest, AGateOnABakeWithoutAQualityPassIsRefusedAtSubmit) {
  struct Case {
    v1::Product product;
    std::optional<uint32_t> quality_views;
    std::string message;
  } cases[] = {
      {v1::PRODUCT_SURFELS, {}, "gate: only atlas and lod-chain bakes are gated"},
      {v1::PRODUCT_CARDS, {}, "gate: only atlas and lod-chain bakes are gated"},
      {v1::PRODUCT_ATLAS, 0, "gate: needs the quality pass, and this request turns it off"},
  };
  for (const Case& c : cases) {
    v1::SubmitBakeRequest r = Gated("rock", 0.5f, {});
    r.mutable_parameters()->set_product(c.product);
    if (c.quality_views) r.mutable_parameters()->set_quality_views(*c.quality_views);
    auto submitted = scheduler_->Submit(r, "ci");
    ASSERT_FALSE(submitted.ok()) << v1::Product_Name(c.product);
    EXPECT_EQ(submitted.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(submitted.status().message().find(c.message), std::string::npos) << submitted.status();
  }
  EXPECT_TRUE(Lease().job_id().empty()) << "nothing was queued";
  // The same bakes without a gate are accepted, and a gated lod chain too.
  v1::SubmitBakeRequest ungated = Request("rock");
  ungated.mutable_parameters()->set_product(v1::PRODUCT_CARDS);
  EXPECT_TRUE(scheduler_->Submit(ungated, "ci").ok());
  v1::SubmitBakeRequest chain = Gated("rock", 0.5f, {});
  chain.mutable_parameters()->set_product(v1::PRODUCT_LOD_CHAIN);
  EXPECT_TRUE(scheduler_->Submit(chain, "ci").ok());
}

TEST_F(GatedSchedulerTest, GateSurvivesARestart) {
  auto r = Submit(Gated("rock", 0.99f, {}), "ci");
  v1::LeasedJob job = Lease();
  Reopen();
  ASSERT_TRUE(scheduler_->Complete(Result(job, 16, 0.9f, 30)).ok());
  EXPECT_EQ(Get(r.job_id()).state(), v1::JOB_STATE_FAILED);
}

}  // namespace
}  // namespace impostor
