// A mixed farm of real worker processes (issue 44), shared by the SQLite and
// the PostgreSQL tests: three lavapipe workers that report different host
// memory (IMPOSTOR_WORKER_TEST_HOST_MEMORY, worker/test_faults.h) and tags,
// and bakes of three sizes whose memory the server estimates with the same
// function the test uses to pick the workers' sizes, so the sizes sit
// between the estimates whatever the estimate's constants become.
#ifndef IMPOSTOR_TESTS_INTEGRATION_MIXED_FARM_H_
#define IMPOSTOR_TESTS_INTEGRATION_MIXED_FARM_H_

#include <gtest/gtest.h>

#include <memory>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "common/request/bake_memory_estimate.h"
#include "common/request/bake_request.h"
#include "tests/support/server_process.h"

namespace impostor::testing::mixed_farm {

// A bake's parameters: `resolution` px, frames x frames, no quality pass
// (its fixed views would make the three sizes' estimates close).
inline v1::BakeParameters Params(uint32_t resolution, uint32_t frames) {
  v1::BakeParameters p;
  p.set_resolution(resolution);
  p.set_frames(frames);
  p.set_quality_views(0);
  return p;
}

// The server's host memory estimate of `p` for a lavapipe worker.
inline int64_t HostEstimate(const v1::BakeParameters& p) {
  absl::StatusOr<v1::BakeParameters> normalised = NormalizeParameters(p);
  EXPECT_TRUE(normalised.ok()) << normalised.status();
  return EstimateBakeMemory(normalised.ok() ? *normalised : p, BakeDevice::kCpu).host_bytes;
}

inline constexpr uint32_t kSmall = 128, kMedium = 512, kLarge = 2048, kImpossible = 8192;

struct Worker {
  std::string name;
  int64_t host_bytes = 0;
  std::string tags;
};

// small holds only the small bakes, medium the small and medium ones, large
// all three; nobody the impossible one.
inline std::vector<Worker> Workers() {
  const int64_t small = HostEstimate(Params(kSmall, 4)), medium = HostEstimate(Params(kMedium, 4)),
                large = HostEstimate(Params(kLarge, 4)), impossible = HostEstimate(Params(kImpossible, 4));
  EXPECT_LT(small, medium);
  EXPECT_LT(medium, large);
  EXPECT_LT(large, impossible);
  return {{"small", small + (medium - small) / 2, "cpu"},
          {"medium", medium + (large - medium) / 2, "cpu"},
          {"large", large + (impossible - large) / 2, "gpu,big"}};
}

inline std::unique_ptr<ChildProcess> StartFarmWorker(const std::string& address, const Worker& w) {
  return StartWorker(address, {"--name=" + w.name, "--tags=" + w.tags},
                     {absl::StrCat("IMPOSTOR_WORKER_TEST_HOST_MEMORY=", w.host_bytes, ":", w.host_bytes)});
}

struct Bake {
  std::string label;
  v1::SubmitBakeRequest request;
  std::set<std::string> may_bake;  // worker names
  std::string job_id;
};

// Two bakes of each size (frames differ, so the cache keys do), and a small
// one that requires the tag only the large worker has.
inline std::vector<Bake> Bakes(const v1::MeshInput& mesh) {
  std::vector<Bake> bakes;
  auto add = [&](std::string label, uint32_t resolution, uint32_t frames, std::set<std::string> may,
                 std::vector<std::string> tags = {}) {
    Bake b;
    b.label = std::move(label);
    *b.request.mutable_mesh() = mesh;
    *b.request.mutable_parameters() = Params(resolution, frames);
    for (const std::string& t : tags) b.request.add_required_tags(t);
    b.may_bake = std::move(may);
    bakes.push_back(std::move(b));
  };
  for (uint32_t frames : {3u, 4u}) {
    add(absl::StrCat("small x", frames), kSmall, frames, {"small", "medium", "large"});
    add(absl::StrCat("medium x", frames), kMedium, frames, {"medium", "large"});
    add(absl::StrCat("large x", frames), kLarge, frames, {"large"});
  }
  add("small, requires gpu", kSmall, 5, {"large"}, {"gpu"});
  return bakes;
}

inline std::string Submit(ServerProcess& server, const v1::SubmitBakeRequest& request) {
  auto ctx = ContextWithin();
  v1::SubmitBakeResponse response;
  const grpc::Status s = server.bake().SubmitBake(ctx.get(), request, &response);
  EXPECT_TRUE(s.ok()) << s.error_message();
  EXPECT_FALSE(response.cached());
  return response.job_id();
}

// Whether a worker id ("large-1234") is one of `names`' workers.
inline bool ByOneOf(const std::string& worker_id, const std::set<std::string>& names) {
  for (const std::string& n : names) {
    if (worker_id.rfind(n + "-", 0) == 0) return true;
  }
  return false;
}

// Every bake succeeded in one attempt, on a worker that holds it.
inline void ExpectEachLandedWhereItFits(v1::BakeService::Stub& bake, const std::vector<Bake>& bakes) {
  for (const Bake& b : bakes) {
    const v1::Job done = WatchToEnd(bake, b.job_id);
    EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << b.label << ": " << done.error().message();
    EXPECT_EQ(done.attempts(), 1u) << b.label << ": a worker failed it for its size?\n" << done.DebugString();
    EXPECT_TRUE(ByOneOf(done.worker_id(), b.may_bake)) << b.label << " baked by " << done.worker_id();
    for (const v1::JobAttempt& a : done.attempt_history()) {
      EXPECT_TRUE(ByOneOf(a.worker_id(), b.may_bake)) << b.label << " attempted by " << a.worker_id();
    }
  }
}

// A bake no worker holds waits queued, with what it needs as its stage and
// no attempt.
inline v1::Job WaitsWithItsReason(v1::BakeService::Stub& bake, const std::string& job_id) {
  const std::string wanted = "waiting for a worker with at least ";
  const v1::Job waiting = WatchUntil(bake, job_id, [&](const v1::Job& j) {
    return j.stage().rfind(wanted, 0) == 0 || IsTerminalState(j.state());
  });
  EXPECT_EQ(waiting.stage().rfind(wanted, 0), 0u) << waiting.stage();
  EXPECT_EQ(waiting.state(), v1::JOB_STATE_QUEUED);
  EXPECT_EQ(waiting.attempts(), 0u);
  return waiting;
}

}  // namespace impostor::testing::mixed_farm

#endif  // IMPOSTOR_TESTS_INTEGRATION_MIXED_FARM_H_
