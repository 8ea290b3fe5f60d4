// A bake request checked, normalised and keyed in one pass, before the
// scheduler sees it (issue 42): the mesh's paths and digests, the
// parameters with their defaults filled in, the priority and request id in
// range, the quality gate valid and applicable to the product, and the
// cache key over the normalised form. BakeScheduler takes this, so it never
// goes back to common/ to ask whether a request is valid.
#ifndef IMPOSTOR_COMMON_REQUEST_NORMALIZED_BAKE_REQUEST_H_
#define IMPOSTOR_COMMON_REQUEST_NORMALIZED_BAKE_REQUEST_H_

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "impostor/v1/bake_service.pb.h"
#include "impostor/v1/types.pb.h"

namespace impostor {

// SubmitBakeRequest.priority range; outside it a submit is INVALID_ARGUMENT.
inline constexpr int32_t kMinPriority = -100;
inline constexpr int32_t kMaxPriority = 100;
// SubmitBakeRequest.request_id: at most this many bytes of [A-Za-z0-9_-].
inline constexpr size_t kMaxRequestIdBytes = 128;

// INVALID_ARGUMENT naming `request_id` and what is wrong with it.
absl::Status ValidateRequestId(std::string_view request_id);

struct NormalizedBakeRequest {
  v1::MeshInput mesh;              // ValidateMeshInput passed
  v1::BakeParameters parameters;   // NormalizeParameters: defaults filled, one product's fields
  v1::QualityGate gate;            // cleared when the request set no target (HasQualityGate)
  bool has_gate = false;
  int32_t priority = 0;            // kMinPriority..kMaxPriority
  std::string request_id;          // ValidateRequestId passed
  std::vector<std::string> required_tags;  // valid worker tags, sorted, no repeats
  std::string cache_key;           // ComputeCacheKey(mesh, parameters)
};

// SubmitBake: every field checked; the first problem is INVALID_ARGUMENT
// naming the field and the limit.
absl::StatusOr<NormalizedBakeRequest> NormalizeSubmit(const v1::SubmitBakeRequest& request);

// SubmitBakeRequest.required_tags: each a valid worker tag (worker_fit.h),
// at most kMaxWorkerTags; sorted, repeats dropped. INVALID_ARGUMENT naming
// the first bad one ("required_tags[1]: ...").
absl::StatusOr<std::vector<std::string>> NormalizeRequiredTags(
    const google::protobuf::RepeatedPtrField<std::string>& tags);

// LookupBake: only what the key depends on (mesh and parameters); the
// gate, priority and request id of a lookup are ignored, as they always were.
absl::StatusOr<NormalizedBakeRequest> NormalizeLookup(const v1::SubmitBakeRequest& request);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_REQUEST_NORMALIZED_BAKE_REQUEST_H_
