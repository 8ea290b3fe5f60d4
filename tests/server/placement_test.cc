// Placement (issue 44): the scheduler leases a job only to a worker whose
// reported capabilities hold it. A bake too large for one worker waits for
// another instead of failing there; one no worker can bake waits with the
// reason as its stage and fails with it after the unplaceable timeout,
// never as a failed attempt; bad capabilities are refused naming the field.
// A fake clock and explicit Lease calls: no sleeps.
#include <functional>
#include <optional>
#include <string>

#include <gtest/gtest.h>

#include "common/error_reason.h"
#include "common/request/worker_fit.h"
#include "tests/server/scheduler_fixture.h"

namespace impostor::testing_support {
namespace {

constexpr int64_t kMB = 1'000'000;
constexpr int64_t kGB = 1'000'000'000;

v1::WorkerCapabilities Caps(int64_t host_bytes, bool ktx2 = true) {
  v1::WorkerCapabilities c;
  c.set_device_kind("cpu");
  c.set_host_memory_bytes(host_bytes);
  c.set_ktx2_encoder(ktx2);
  c.set_baker_version("test");
  return c;
}

class Placement : public SchedulerFixture {
 protected:
  absl::StatusOr<std::optional<v1::LeasedJob>> TryLease(const std::string& worker, const v1::WorkerCapabilities* caps) {
    v1::LeaseJobRequest r;
    r.set_worker_id(worker);
    if (caps != nullptr) *r.mutable_capabilities() = *caps;
    return scheduler_->Lease(r, std::chrono::steady_clock::now(), nullptr);
  }
  v1::LeasedJob LeaseAs(const std::string& worker, const v1::WorkerCapabilities& caps) {
    auto job = TryLease(worker, &caps);
    EXPECT_TRUE(job.ok()) << job.status();
    return job.ok() && job->has_value() ? **job : v1::LeasedJob();
  }
  // 4096 px at supersampling 2 on a CPU device: gigabytes of host memory.
  v1::SubmitBakeRequest Large(const std::string& content) {
    v1::SubmitBakeRequest r = Request(content);
    r.mutable_parameters()->set_resolution(4096);
    r.mutable_parameters()->set_supersampling(2);
    return r;
  }
  v1::Job Job(const std::string& id) {
    auto job = scheduler_->GetJob(id);
    EXPECT_TRUE(job.ok()) << job.status();
    return job.ok() ? *job : v1::Job();
  }
};

TEST_F(Placement, ABakeTooLargeForOneWorkerWaitsForOneThatHoldsIt) {
  const std::string id = Submit(Large("tree"), "ci").job_id();
  EXPECT_TRUE(LeaseAs("small", Caps(100 * kMB)).job_id().empty());
  v1::Job waiting = Job(id);
  EXPECT_EQ(waiting.state(), v1::JOB_STATE_QUEUED);
  EXPECT_EQ(waiting.attempts(), 0u);
  EXPECT_EQ(waiting.stage().rfind("waiting for a worker with at least ", 0), 0u) << waiting.stage();
  EXPECT_NE(waiting.stage().find(" of host memory (the most any worker has: 100 MB) for an atlas of 4096 px at "
                                 "supersampling 2"),
            std::string::npos)
      << waiting.stage();

  const v1::LeasedJob leased = LeaseAs("big", Caps(64 * kGB));
  ASSERT_EQ(leased.job_id(), id);
  const v1::Job running = Job(id);
  EXPECT_EQ(running.attempts(), 1u);  // the small worker never had it
  ASSERT_EQ(running.attempt_history_size(), 1);
  EXPECT_EQ(running.attempt_history(0).worker_id(), "big");
}

TEST_F(Placement, AJobNoWorkerCanBakeFailsAfterTheTimeoutNamingWhatItNeeds) {
  const std::string id = Submit(Large("tree"), "ci").job_id();
  EXPECT_TRUE(LeaseAs("small", Caps(100 * kMB)).job_id().empty());
  now_ms_ += 3600'000 - 1;  // the default --unplaceable-timeout-seconds, less 1 ms
  EXPECT_TRUE(LeaseAs("small", Caps(100 * kMB)).job_id().empty());
  EXPECT_EQ(Job(id).state(), v1::JOB_STATE_QUEUED);
  now_ms_ += 1;
  EXPECT_TRUE(LeaseAs("small", Caps(100 * kMB)).job_id().empty());
  const v1::Job failed = Job(id);
  ASSERT_EQ(failed.state(), v1::JOB_STATE_FAILED);
  EXPECT_EQ(failed.attempts(), 0u);  // a placement decision, never a failed attempt
  EXPECT_EQ(failed.error().code(), static_cast<int32_t>(absl::StatusCode::kResourceExhausted));
  EXPECT_EQ(failed.error().reason(), error_reason::kUnplaceable);
  EXPECT_EQ(failed.error().message().rfind("no worker could bake it for 3600 s (--unplaceable-timeout-seconds): "
                                           "waiting for a worker with at least ",
                                           0),
            0u)
      << failed.error().message();

  // The small worker still bakes what fits it.
  v1::SubmitBakeRequest small = Request("leaf");
  small.mutable_parameters()->set_resolution(128);
  const std::string small_id = Submit(small, "ci").job_id();
  EXPECT_EQ(LeaseAs("small", Caps(100 * kMB)).job_id(), small_id);
}

TEST_F(Placement, KtxMapsGoOnlyToAWorkerWithTheEncoder) {
  v1::SubmitBakeRequest r = Request("tree");
  r.mutable_parameters()->set_resolution(256);
  r.mutable_parameters()->set_texture_format(v1::TEXTURE_FORMAT_KTX2);
  const std::string id = Submit(r, "ci").job_id();
  EXPECT_TRUE(LeaseAs("no-basisu", Caps(64 * kGB, /*ktx2=*/false)).job_id().empty());
  EXPECT_EQ(Job(id).stage().rfind("waiting for a worker with the KTX2 encoder (basisu; none of the 1 workers seen "
                                  "has it)",
                                  0),
            0u)
      << Job(id).stage();
  EXPECT_EQ(LeaseAs("with-basisu", Caps(64 * kGB)).job_id(), id);
}

TEST_F(Placement, AWorkerThatReportsNothingIsLeasedAnything) {
  const std::string id = Submit(Large("tree"), "ci").job_id();
  auto job = TryLease("old-worker", nullptr);
  ASSERT_TRUE(job.ok()) << job.status();
  ASSERT_TRUE(job->has_value());
  EXPECT_EQ((*job)->job_id(), id);
}

TEST_F(Placement, TheTimeoutCountsFromWhenNoWorkerThatFitsIsAbout) {
  const std::string first = Submit(Large("tree"), "ci").job_id();
  const std::string second = Submit(Large("rock"), "ci").job_id();
  ASSERT_EQ(LeaseAs("big", Caps(64 * kGB)).job_id(), first);  // busy with the first, heard from just now
  EXPECT_TRUE(LeaseAs("small", Caps(100 * kMB)).job_id().empty());
  EXPECT_EQ(Job(second).stage(), "queued");  // the big worker can take it once free

  // Two hours on, the big worker not heard from (more than a lease timeout):
  // the second job now waits for a worker, and its hour starts now.
  now_ms_ += 7200'000;
  EXPECT_TRUE(LeaseAs("small", Caps(100 * kMB)).job_id().empty());
  const v1::Job waiting = Job(second);
  EXPECT_EQ(waiting.state(), v1::JOB_STATE_QUEUED);
  EXPECT_EQ(waiting.stage().rfind("waiting for a worker with at least ", 0), 0u) << waiting.stage();
  now_ms_ += 3600'000 - 1;
  EXPECT_TRUE(LeaseAs("small", Caps(100 * kMB)).job_id().empty());
  EXPECT_EQ(Job(second).state(), v1::JOB_STATE_QUEUED);
}

TEST_F(Placement, BadCapabilitiesAreRefusedNamingTheField) {
  struct Case {
    const char* name;
    std::function<void(v1::WorkerCapabilities&)> spoil;
    const char* message;
  };
  const Case cases[] = {
      {"upper-case tag", [](auto& c) { c.add_tags("GPU"); }, "capabilities.tags[0]: a tag is 1..64 bytes of [a-z0-9._-]"},
      {"empty tag", [](auto& c) { c.add_tags("gpu"); c.add_tags(""); }, "capabilities.tags[1]:"},
      {"17 tags", [](auto& c) { for (int i = 0; i < 17; ++i) c.add_tags("t" + std::to_string(i)); },
       "capabilities.tags: 17 tags, the limit is 16"},
      {"negative memory", [](auto& c) { c.set_host_memory_bytes(-1); },
       "capabilities.host_memory_bytes: -1 bytes is negative"},
      {"long device kind", [](auto& c) { c.set_device_kind(std::string(17, 'x')); },
       "capabilities.device_kind: 17 bytes; at most 16"},
      {"long baker version", [](auto& c) { c.set_baker_version(std::string(65, 'v')); },
       "capabilities.baker_version: 65 bytes; at most 64"},
  };
  for (const Case& c : cases) {
    v1::WorkerCapabilities caps = Caps(kGB);
    c.spoil(caps);
    auto job = TryLease("w", &caps);
    ASSERT_FALSE(job.ok()) << c.name;
    EXPECT_EQ(job.status().code(), absl::StatusCode::kInvalidArgument) << c.name;
    EXPECT_NE(job.status().message().find(c.message), std::string::npos) << c.name << ": " << job.status();
  }
}

TEST(WorkerFit, NamesTheFirstShortfallAndChecksOnlyWhatWasReported) {
  v1::BakeParameters p;
  p.set_product(v1::PRODUCT_ATLAS);
  p.set_resolution(16384);
  p.set_frames(16);
  p.set_supersampling(1);
  v1::WorkerCapabilities gpu;
  gpu.set_device_kind("discrete");
  gpu.set_ktx2_encoder(true);
  EXPECT_FALSE(WorkerShortfall(p, gpu).has_value());  // nothing reported, nothing checked
  gpu.set_max_allocation_bytes(256 * kMB);
  auto s = WorkerShortfall(p, gpu);
  ASSERT_TRUE(s.has_value());
  EXPECT_EQ(s->what, "device allocation");
  EXPECT_GT(s->need_bytes, s->have_bytes);
  gpu.set_max_allocation_bytes(64 * kGB);
  gpu.set_device_memory_bytes(1 * kGB);
  s = WorkerShortfall(p, gpu);
  ASSERT_TRUE(s.has_value());
  EXPECT_EQ(s->what, "device memory");
  gpu.set_device_memory_bytes(80 * kGB);
  EXPECT_FALSE(WorkerShortfall(p, gpu).has_value());
  EXPECT_EQ(UnplaceableReason(p, {}), "");  // no worker: nothing to judge by
  v1::WorkerCapabilities small = gpu;
  small.set_device_memory_bytes(1 * kGB);
  EXPECT_EQ(UnplaceableReason(p, {small, gpu}), "");  // one of them can
  const std::string reason = UnplaceableReason(p, {small});
  EXPECT_NE(reason.find("of device memory (the most any worker has: 1.0 GB) for an atlas of 16384 px"),
            std::string::npos)
      << reason;
}

// A request's required tags (issue 44): only a worker with every one of
// them is leased the job; until one asks, the job waits with the tags as
// its stage, never as a failed attempt.
TEST_F(Placement, ARequestWithRequiredTagsGoesOnlyToAWorkerWithThemAll) {
  v1::SubmitBakeRequest request = Request("hero");
  request.add_required_tags("gpu");
  request.add_required_tags("team-forest");
  const std::string id = Submit(request, "ci").job_id();

  v1::WorkerCapabilities gpu_only = Caps(64 * kGB);
  gpu_only.add_tags("gpu");
  EXPECT_TRUE(LeaseAs("laptop", Caps(64 * kGB)).job_id().empty());
  EXPECT_TRUE(LeaseAs("render-1", gpu_only).job_id().empty());
  auto silent = TryLease("old-worker", nullptr);  // reports nothing: no tags
  ASSERT_TRUE(silent.ok()) << silent.status();
  EXPECT_FALSE(silent->has_value());
  const v1::Job waiting = Job(id);
  EXPECT_EQ(waiting.state(), v1::JOB_STATE_QUEUED);
  EXPECT_EQ(waiting.attempts(), 0u);
  EXPECT_EQ(waiting.stage().rfind("waiting for a worker tagged gpu, team-forest (none of the 3 workers seen has them "
                                  "all) for an atlas of ",
                                  0),
            0u)
      << waiting.stage();

  v1::WorkerCapabilities forest = gpu_only;
  forest.add_tags("team-forest");
  ASSERT_EQ(LeaseAs("render-2", forest).job_id(), id);
  EXPECT_EQ(Job(id).attempts(), 1u);

  // An untagged request may still go anywhere, a silent worker included.
  const std::string any = Submit(Request("rock"), "ci").job_id();
  auto taken = TryLease("old-worker", nullptr);
  ASSERT_TRUE(taken.ok() && taken->has_value());
  EXPECT_EQ((*taken)->job_id(), any);
}

}  // namespace
}  // namespace impostor::testing_support
