// Preference among eligible workers (issue 44): a large bake waits, for at
// most SchedulerOptions::prefer_strong_ms, for the strongest worker about
// that could take it; small bakes go to whoever asks. The pure rules
// (server/scheduler/worker_strength.h) table by table, then the scheduler
// with a fake clock and explicit Lease calls by fake workers reporting
// hand-written capabilities (so "discrete" needs no GPU): no sleeps.
#include <optional>
#include <string>

#include <gtest/gtest.h>

#include "server/scheduler/worker_strength.h"
#include "tests/server/scheduler_fixture.h"

namespace impostor::testing_support {
namespace {

constexpr int64_t kGB = 1'000'000'000;
constexpr int64_t kBoundMs = 5'000;

v1::WorkerCapabilities Caps(const std::string& kind, int64_t host_bytes = 64 * kGB) {
  v1::WorkerCapabilities c;
  c.set_device_kind(kind);
  c.set_host_memory_bytes(host_bytes);
  c.set_ktx2_encoder(true);
  c.set_baker_version("test");
  return c;
}

v1::BakeParameters Params(uint32_t resolution, std::optional<uint32_t> supersampling) {
  v1::BakeParameters p;
  p.set_resolution(resolution);
  if (supersampling) p.set_supersampling(*supersampling);
  return p;
}

TEST(WorkerStrength, DiscreteOverIntegratedVirtualAndOtherOverCpu) {
  const struct {
    const char* kind;
    int strength;
  } cases[] = {{"discrete", 3}, {"integrated", 2}, {"virtual", 2}, {"other", 2},
               {"npu", 2},      {"cpu", 1},        {"", 0}};
  for (const auto& c : cases) {
    const v1::WorkerCapabilities caps = Caps(c.kind);
    EXPECT_EQ(WorkerStrength(&caps), c.strength) << "device_kind \"" << c.kind << "\"";
  }
  EXPECT_EQ(WorkerStrength(nullptr), 0) << "a worker that reports nothing";
}

TEST(WorkerStrength, ALargeBakeRendersAtLeast8192PxASide) {
  const struct {
    const char* name;
    uint32_t resolution;
    std::optional<uint32_t> supersampling;
    bool large;
  } cases[] = {
      {"4096 px at supersampling 2", 4096, 2, true},
      {"8192 px at supersampling 1", 8192, 1, true},
      {"8192 px, supersampling unset (renders at 1)", 8192, std::nullopt, true},
      {"the default, 2048 px at supersampling 2", 2048, 2, false},
      {"4096 px, supersampling unset", 4096, std::nullopt, false},
      {"8191 px at supersampling 1", 8191, 1, false},
      {"2048 px at supersampling 4", 2048, 4, true},
  };
  for (const auto& c : cases) EXPECT_EQ(IsLargeBake(Params(c.resolution, c.supersampling)), c.large) << c.name;
}

TEST(WorkerStrength, ALargeBakeIsHeldForAStrongerWorkerUntilTheBound) {
  const v1::BakeParameters large = Params(4096, 2);
  const v1::BakeParameters small = Params(1024, 2);
  const struct {
    const char* name;
    const v1::BakeParameters& params;
    int asker;
    int strongest_other;
    int64_t waited_ms;
    int64_t bound_ms;
    bool hold;
  } cases[] = {
      {"cpu asks, discrete about, just queued", large, 1, 3, 0, kBoundMs, true},
      {"cpu asks, integrated about", large, 1, 2, 0, kBoundMs, true},
      {"1 ms before the bound", large, 1, 3, kBoundMs - 1, kBoundMs, true},
      {"at the bound", large, 1, 3, kBoundMs, kBoundMs, false},
      {"past the bound", large, 1, 3, kBoundMs + 60'000, kBoundMs, false},
      {"preference off (bound 0)", large, 1, 3, 0, 0, false},
      {"a small bake goes anywhere", small, 1, 3, 0, kBoundMs, false},
      {"the asker is as strong", large, 3, 3, 0, kBoundMs, false},
      {"the asker is stronger", large, 3, 1, 0, kBoundMs, false},
      {"no other worker", large, 1, 0, 0, kBoundMs, false},
      {"the asker reports no kind", large, 0, 3, 0, kBoundMs, false},
  };
  for (const auto& c : cases) {
    EXPECT_EQ(HoldForStrongerWorker(c.params, c.asker, c.strongest_other, c.waited_ms, c.bound_ms), c.hold) << c.name;
  }
  EXPECT_EQ(StrongerWorkerStage("discrete", 30'000), "waiting for a stronger worker (discrete) for up to 30 s");
}

class StrongWorkerPreference : public SchedulerFixture {
 protected:
  void SetUp() override {
    SchedulerFixture::SetUp();
    UseBound(kBoundMs);
  }
  void UseBound(int64_t bound_ms) {
    scheduler_.reset();
    scheduler_ = std::make_unique<BakeScheduler>(jobs_.get(), blobs_.get(),
                                                 SchedulerOptions{.lease_timeout_ms = 30'000,
                                                                  .max_attempts = 3,
                                                                  .prefer_strong_ms = bound_ms,
                                                                  .now_ms = [this] { return now_ms_; }});
  }
  // One LeaseJob call that returns at once; empty job_id when nothing is
  // leased. `caps` null: the worker reports nothing.
  std::string LeaseAs(const std::string& worker, const v1::WorkerCapabilities* caps) {
    v1::LeaseJobRequest r;
    r.set_worker_id(worker);
    if (caps != nullptr) *r.mutable_capabilities() = *caps;
    auto job = scheduler_->Lease(r, std::chrono::steady_clock::now(), nullptr);
    EXPECT_TRUE(job.ok()) << job.status();
    return job.ok() && job->has_value() ? (*job)->job_id() : "";
  }
  std::string SubmitSized(const std::string& content, uint32_t resolution) {
    v1::SubmitBakeRequest r = Request(content);
    r.mutable_parameters()->set_resolution(resolution);
    r.mutable_parameters()->set_supersampling(2);
    return Submit(r, "ci").job_id();
  }
  v1::Job Job(const std::string& id) {
    auto job = scheduler_->GetJob(id);
    EXPECT_TRUE(job.ok()) << job.status();
    return job.ok() ? *job : v1::Job();
  }

  const v1::WorkerCapabilities cpu_ = Caps("cpu");
  const v1::WorkerCapabilities discrete_ = Caps("discrete");
};

TEST_F(StrongWorkerPreference, ALargeBakeGoesToTheDiscreteWorkerAndASmallOneToTheCpuWorker) {
  // Both poll an empty queue first: both are about.
  EXPECT_EQ(LeaseAs("lavapipe", &cpu_), "");
  EXPECT_EQ(LeaseAs("rtx", &discrete_), "");
  const std::string large = SubmitSized("cathedral", 4096);  // older: first in the queue
  const std::string small = SubmitSized("pebble", 512);

  EXPECT_EQ(LeaseAs("lavapipe", &cpu_), small) << "the cpu worker reads past the large bake";
  const v1::Job held = Job(large);
  EXPECT_EQ(held.state(), v1::JOB_STATE_QUEUED);
  EXPECT_EQ(held.attempts(), 0u);
  EXPECT_EQ(held.stage(), "waiting for a stronger worker (discrete) for up to 5 s");
  EXPECT_EQ(LeaseAs("lavapipe", &cpu_), "") << "nothing else it may take";

  EXPECT_EQ(LeaseAs("rtx", &discrete_), large);
  const v1::Job running = Job(large);
  ASSERT_EQ(running.attempt_history_size(), 1);
  EXPECT_EQ(running.attempt_history(0).worker_id(), "rtx");
}

TEST_F(StrongWorkerPreference, WithOnlyTheCpuWorkerPollingTheLargeBakeIsTakenAfterTheBound) {
  EXPECT_EQ(LeaseAs("rtx", &discrete_), "");  // heard from, then quiet (still within the lease timeout)
  const std::string large = SubmitSized("cathedral", 4096);
  EXPECT_EQ(LeaseAs("lavapipe", &cpu_), "");
  now_ms_ += kBoundMs - 2;  // Submit advanced the clock 1 ms: queued for kBoundMs - 1
  EXPECT_EQ(LeaseAs("lavapipe", &cpu_), "");
  EXPECT_EQ(Job(large).stage(), "waiting for a stronger worker (discrete) for up to 5 s");
  now_ms_ += 1;
  EXPECT_EQ(LeaseAs("lavapipe", &cpu_), large);
  EXPECT_EQ(Job(large).attempt_history(0).worker_id(), "lavapipe");
}

TEST_F(StrongWorkerPreference, AStrongerWorkerNotHeardFromForALeaseTimeoutHoldsNothingBack) {
  EXPECT_EQ(LeaseAs("rtx", &discrete_), "");
  now_ms_ += 30'000;  // the lease timeout: the discrete worker is no longer about
  const std::string large = SubmitSized("cathedral", 4096);
  EXPECT_EQ(LeaseAs("lavapipe", &cpu_), large);
}

TEST_F(StrongWorkerPreference, AStrongerWorkerThatCannotTakeTheBakeHoldsNothingBack) {
  const v1::WorkerCapabilities tiny_discrete = Caps("discrete", 100'000'000);  // 100 MB of host memory
  EXPECT_EQ(LeaseAs("old-card", &tiny_discrete), "");
  const std::string large = SubmitSized("cathedral", 4096);
  EXPECT_EQ(LeaseAs("lavapipe", &cpu_), large);
}

TEST_F(StrongWorkerPreference, AWorkerThatReportsNothingIsNeitherHeldBackNorWaitedFor) {
  EXPECT_EQ(LeaseAs("old-worker", nullptr), "");
  const std::string first = SubmitSized("cathedral", 4096);
  EXPECT_EQ(LeaseAs("lavapipe", &cpu_), first) << "the silent worker is not waited for";
  EXPECT_EQ(LeaseAs("rtx", &discrete_), "");
  const std::string second = SubmitSized("palace", 4096);
  EXPECT_EQ(LeaseAs("old-worker", nullptr), second) << "the silent worker does not wait";
}

TEST_F(StrongWorkerPreference, ABoundOfZeroTurnsThePreferenceOff) {
  UseBound(0);
  EXPECT_EQ(LeaseAs("rtx", &discrete_), "");
  const std::string large = SubmitSized("cathedral", 4096);
  EXPECT_EQ(LeaseAs("lavapipe", &cpu_), large);
}

}  // namespace
}  // namespace impostor::testing_support
