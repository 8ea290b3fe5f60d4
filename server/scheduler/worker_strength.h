// Preference among eligible workers (issue 44): a large bake waits a bounded
// while for the strongest worker about instead of going to the first one
// that asks. Pure functions over what workers report (v1::WorkerCapabilities)
// and a bake's normalised parameters; BakeScheduler::LeaseCandidates
// applies them (bake_scheduler_leases.cc). Thread-safe.
//
// Strength is the device kind's rank alone. A measured throughput (texels a
// second of job time) would order workers of one kind too, but one slow
// bake on a busy host would flip it; the kinds differ by an order of
// magnitude (lavapipe against a discrete GPU), which is what the wait is for.
#ifndef IMPOSTOR_SERVER_SCHEDULER_WORKER_STRENGTH_H_
#define IMPOSTOR_SERVER_SCHEDULER_WORKER_STRENGTH_H_

#include <cstdint>
#include <string>
#include <string_view>

#include "impostor/v1/types.pb.h"
#include "impostor/v1/worker_service.pb.h"

namespace impostor {

// WorkerCapabilities.device_kind ranked: 3 "discrete", 2 "integrated",
// "virtual" or any other named kind, 1 "cpu", 0 unknown (an empty kind). A
// worker that reports no capabilities is unknown too. Unknown workers are
// outside the preference: they never wait and are never waited for, so a
// farm of workers older than capabilities behaves as before.
int DeviceStrength(std::string_view device_kind);
int WorkerStrength(const v1::WorkerCapabilities* caps);

// A bake is large when it renders at least kLargeBakeRenderedPx texels a
// side (resolution x supersampling; an unset supersampling counts as 1): 4x
// the texels of the default bake (2048 px at supersampling 2), e.g. 4096 px
// at supersampling 2 or 8192 px at 1. Render time grows with the texels, and
// at this size a CPU device (lavapipe) takes minutes where a discrete GPU
// takes seconds; the default bake is not large, so a farm baking defaults
// keeps every worker busy.
inline constexpr int64_t kLargeBakeRenderedPx = 8192;
bool IsLargeBake(const v1::BakeParameters& normalised);

// Whether a queued bake of `normalised`, waiting for `waited_ms` (>= 0), is
// held back from a worker of strength `asker` because a worker of strength
// `strongest_other` that could take it is about: only large bakes, only
// between known strengths (> 0), only while `bound_ms` (0 = never) has not
// passed, so no bake waits longer than the bound.
bool HoldForStrongerWorker(const v1::BakeParameters& normalised, int asker, int strongest_other, int64_t waited_ms,
                           int64_t bound_ms);

// The held job's stage: "waiting for a stronger worker (discrete) for up to
// 30 s". `device_kind` is the stronger worker's reported kind (validated
// printable ASCII, ValidateCapabilities).
std::string StrongerWorkerStage(std::string_view device_kind, int64_t bound_ms);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_SCHEDULER_WORKER_STRENGTH_H_
