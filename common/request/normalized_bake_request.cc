#include "common/request/normalized_bake_request.h"

#include <algorithm>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "common/request/bake_request.h"
#include "common/request/quality_gate.h"
#include "common/request/worker_fit.h"

namespace impostor {

absl::Status ValidateRequestId(std::string_view request_id) {
  if (request_id.size() > kMaxRequestIdBytes) {
    return absl::InvalidArgumentError(absl::StrCat("request_id: ", request_id.size(), " bytes is over the limit of ",
                                                   kMaxRequestIdBytes));
  }
  for (size_t i = 0; i < request_id.size(); ++i) {
    const char c = request_id[i];
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
    if (!ok) {
      return absl::InvalidArgumentError(absl::StrCat("request_id: byte ", i, " (0x",
                                                     absl::Hex(static_cast<unsigned char>(c), absl::kZeroPad2),
                                                     ") is not one of [A-Za-z0-9_-]"));
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<std::vector<std::string>> NormalizeRequiredTags(
    const google::protobuf::RepeatedPtrField<std::string>& tags) {
  return NormalizeRequiredTagList({tags.begin(), tags.end()}, "required_tags", /*indexed=*/true);
}

absl::StatusOr<NormalizedBakeRequest> NormalizeLookup(const v1::SubmitBakeRequest& request) {
  if (auto s = ValidateMeshInput(request.mesh()); !s.ok()) return s;
  auto params = NormalizeParameters(request.parameters());
  if (!params.ok()) return params.status();
  NormalizedBakeRequest out;
  out.mesh = request.mesh();
  out.parameters = *std::move(params);
  out.cache_key = ComputeCacheKey(out.mesh, out.parameters);
  return out;
}

absl::StatusOr<NormalizedBakeRequest> NormalizeSubmit(const v1::SubmitBakeRequest& request) {
  // The order of the checks is the order of the errors a client sees; kept
  // as BakeScheduler::Submit had it.
  if (auto s = ValidateMeshInput(request.mesh()); !s.ok()) return s;
  auto params = NormalizeParameters(request.parameters());
  if (!params.ok()) return params.status();
  if (request.priority() < kMinPriority || request.priority() > kMaxPriority) {
    return absl::InvalidArgumentError(absl::StrCat("priority: ", request.priority(), " is out of range ", kMinPriority,
                                                   "..", kMaxPriority));
  }
  if (auto s = ValidateQualityGate(request.gate(), "gate"); !s.ok()) return s;
  if (auto s = CheckQualityGateApplies(request.gate(), *params, "gate"); !s.ok()) return s;
  if (auto s = ValidateRequestId(request.request_id()); !s.ok()) return s;
  absl::StatusOr<std::vector<std::string>> tags = NormalizeRequiredTags(request.required_tags());
  if (!tags.ok()) return tags.status();
  NormalizedBakeRequest out;
  out.required_tags = *std::move(tags);
  out.mesh = request.mesh();
  out.parameters = *std::move(params);
  out.has_gate = HasQualityGate(request.gate());
  if (out.has_gate) out.gate = request.gate();
  out.priority = request.priority();
  out.request_id = request.request_id();
  out.cache_key = ComputeCacheKey(out.mesh, out.parameters);
  return out;
}

}  // namespace impostor
