// Whether a worker can bake a request, from what it reported
// (v1::WorkerCapabilities) and the request's memory estimate
// (bake_memory_estimate.h): the server leases a job only to a worker it
// fits (issue 44), so a bake too large for one worker waits for another
// instead of failing there. The worker still checks for itself
// (worker/bake_memory_check.h): a worker that reports nothing is leased
// anything.
#ifndef IMPOSTOR_COMMON_REQUEST_WORKER_FIT_H_
#define IMPOSTOR_COMMON_REQUEST_WORKER_FIT_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "impostor/v1/types.pb.h"
#include "impostor/v1/worker_service.pb.h"

namespace impostor {

// WorkerCapabilities limits.
inline constexpr int kMaxWorkerTags = 16;
inline constexpr size_t kMaxWorkerTagBytes = 64;
inline constexpr size_t kMaxDeviceKindBytes = 16;
inline constexpr size_t kMaxBakerVersionBytes = 64;

// INVALID_ARGUMENT naming the first field out of range, under `field`
// (e.g. "capabilities.tags[2]: \"GPU\" is not 1..64 bytes of [a-z0-9._-]").
absl::Status ValidateCapabilities(const v1::WorkerCapabilities& caps, const char* field = "capabilities");

// One tag as --tags and capabilities.tags take it: 1..64 bytes of [a-z0-9._-].
bool IsValidWorkerTag(const std::string& tag);

// A list of required tags (a request's required_tags, a token's
// --require-tag): at most kMaxWorkerTags, each IsValidWorkerTag, returned
// sorted without repeats. INVALID_ARGUMENT under `field`, a bad tag named as
// field[i] when `indexed` (e.g. "required_tags[2]: \"GPU\" is not 1..64 bytes
// of [a-z0-9._-]"), as `field` alone otherwise.
absl::StatusOr<std::vector<std::string>> NormalizeRequiredTagList(std::vector<std::string> tags, const char* field,
                                                                  bool indexed);

// What a bake lacks on a worker.
struct Shortfall {
  std::string what;        // "host memory", "device memory", "device allocation", "KTX2 encoder"
  int64_t need_bytes = 0;  // 0 for the encoder
  int64_t have_bytes = 0;
};

// The first thing the bake of `normalised` (NormalizeParameters' output)
// needs beyond `caps`; nullopt when it fits. A figure the worker did not
// report (0) is not checked.
std::optional<Shortfall> WorkerShortfall(const v1::BakeParameters& normalised, const v1::WorkerCapabilities& caps);

// Why no worker of `workers` (those heard from lately) can bake
// `normalised`, for the job's stage and error: "waiting for a worker with at
// least 134 MB of host memory (the most any worker has: 100 MB) for an
// atlas of 1024 px at supersampling 2 (frames 8)". "" when one of them can,
// or when `workers` is empty (no worker: nothing to judge by).
// With `required_tags` (SubmitBakeRequest.required_tags), only the workers
// that have them all count, and when none has: "waiting for a worker tagged
// gpu (none of the 3 workers seen has it) for ...".
std::string UnplaceableReason(const v1::BakeParameters& normalised,
                              const std::vector<v1::WorkerCapabilities>& workers,
                              const std::vector<std::string>& required_tags = {});

// Whether a worker that reported `caps` (null: nothing) has every tag of
// `required`: always with none required, never without capabilities.
bool HasRequiredTags(const v1::WorkerCapabilities* caps, const std::vector<std::string>& required);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_REQUEST_WORKER_FIT_H_
