#include "server/auth/access_policy.h"

#include <algorithm>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

constexpr Role R = Role::kReader;
constexpr Role S = Role::kSubmitter;
constexpr Role W = Role::kWorker;

}  // namespace

const std::vector<MethodRule>& AccessRules() {
  // Roles nest for clients (submitter = reader + submitting); workers are
  // apart: they can bake and publish, nothing else, and readers and
  // submitters can never publish a result (the forged-result attack of
  // issue 14). Admin may call everything, listed or not.
  static const auto* rules = new std::vector<MethodRule>{
      {"/impostor.v1.AssetService/GetResult", {R, S}},
      {"/impostor.v1.AssetService/ReadBlob", {R, S, W}, ObjectCheck::kReadableBlob},
      // Each digest is checked under ReadBlob's rule by the service's guard.
      {"/impostor.v1.AssetService/BatchReadBlobs", {R, S, W}},
      {"/impostor.v1.AssetService/FindMissingBlobs", {S, W}},
      {"/impostor.v1.AssetService/UploadBlob", {S, W}, ObjectCheck::kNone, true},
      // As UploadBlob, with its quota (checked by the service's guard).
      {"/impostor.v1.AssetService/BatchUpdateBlobs", {S, W}, ObjectCheck::kNone, true},
      // Who may upload may ask how far an upload got.
      {"/impostor.v1.AssetService/QueryUpload", {S, W}},
      {"/impostor.v1.AssetService/PinResult", {}, ObjectCheck::kNone, true},
      {"/impostor.v1.BakeService/LookupBake", {R, S}},
      {"/impostor.v1.BakeService/SubmitBake", {S}, ObjectCheck::kNone, true},
      {"/impostor.v1.BakeService/WatchJob", {S}, ObjectCheck::kOwnJob},
      {"/impostor.v1.BakeService/GetJob", {S}, ObjectCheck::kOwnJob},
      {"/impostor.v1.BakeService/CancelJob", {S}, ObjectCheck::kOwnJob, true},
      {"/impostor.v1.WorkerService/LeaseJob", {W}, ObjectCheck::kNone, true},
      {"/impostor.v1.WorkerService/ReportProgress", {W}, ObjectCheck::kOwnLease},
      {"/impostor.v1.WorkerService/CompleteJob", {W}, ObjectCheck::kOwnLease, true},
      {"/impostor.v1.WorkerService/FailJob", {W}, ObjectCheck::kOwnLease, true},
      {"/impostor.v1.WorkerService/ReleaseJob", {W}, ObjectCheck::kOwnLease, true},
      // Administration: admin tokens only (no role listed), audited.
      {"/impostor.v1.AdminService/PurgeWorkerResults", {}, ObjectCheck::kNone, true},
  };
  return *rules;
}

const MethodRule* FindRule(std::string_view method) {
  for (const MethodRule& rule : AccessRules()) {
    if (rule.method == method) return &rule;
  }
  return nullptr;
}

absl::Status AuthorizeMethod(const Principal& principal, std::string_view method) {
  if (principal.role == Role::kAdmin) return absl::OkStatus();
  const MethodRule* rule = FindRule(method);
  if (rule != nullptr && std::find(rule->roles.begin(), rule->roles.end(), principal.role) != rule->roles.end()) {
    return absl::OkStatus();
  }
  std::string needed;
  if (rule != nullptr) {
    for (Role r : rule->roles) absl::StrAppend(&needed, std::string(RoleName(r)), " or ");
  }
  absl::StrAppend(&needed, "admin");
  return absl::PermissionDeniedError(absl::StrCat(std::string(method), " needs role ", needed, "; token '",
                                                  principal.name, "' has role ",
                                                  std::string(RoleName(principal.role))));
}

}  // namespace impostor
