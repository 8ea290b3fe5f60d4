#include "server/scheduler/worker_strength.h"

#include <algorithm>

#include "absl/strings/str_cat.h"

namespace impostor {

int DeviceStrength(std::string_view device_kind) {
  if (device_kind.empty()) return 0;
  if (device_kind == "discrete") return 3;
  if (device_kind == "cpu") return 1;
  return 2;  // "integrated", "virtual", "other", a kind newer than this server
}

int WorkerStrength(const v1::WorkerCapabilities* caps) {
  return caps == nullptr ? 0 : DeviceStrength(caps->device_kind());
}

bool IsLargeBake(const v1::BakeParameters& normalised) {
  const int64_t supersampling = std::max<int64_t>(1, normalised.supersampling());
  return int64_t{normalised.resolution()} * supersampling >= kLargeBakeRenderedPx;
}

bool HoldForStrongerWorker(const v1::BakeParameters& normalised, int asker, int strongest_other, int64_t waited_ms,
                           int64_t bound_ms) {
  if (bound_ms <= 0 || asker <= 0 || strongest_other <= asker) return false;
  return waited_ms < bound_ms && IsLargeBake(normalised);
}

std::string StrongerWorkerStage(std::string_view device_kind, int64_t bound_ms) {
  return absl::StrCat("waiting for a stronger worker (", std::string(device_kind), ") for up to ", bound_ms / 1000, " s");
}

}  // namespace impostor
