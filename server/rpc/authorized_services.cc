#include "server/rpc/authorized_services.h"

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "common/util/log_escape.h"
#include "server/auth/access_policy.h"
#include "server/rpc/batch_read_request.h"
#include "server/rpc/batch_update_request.h"
#include "server/rpc/grpc_status.h"

namespace impostor {
namespace {

constexpr char kAsset[] = "/impostor.v1.AssetService/";
constexpr char kBake[] = "/impostor.v1.BakeService/";
constexpr char kWorker[] = "/impostor.v1.WorkerService/";
constexpr char kAdmin[] = "/impostor.v1.AdminService/";

std::string Method(const char* service, const char* name) { return absl::StrCat(service, name); }

}  // namespace

grpc::Status AccessGuard::Run(grpc::ServerContext* context, std::string_view method, const std::string& object,
                              const Handler& handler, const std::function<std::string()>& describe) {
  if (authenticator_ == nullptr) return handler(Principal{});
  const auto& metadata = context->client_metadata();
  std::string header;
  const auto it = metadata.find("authorization");
  if (it != metadata.end()) header.assign(it->second.data(), it->second.size());
  auto principal = authenticator_->Authenticate(it == metadata.end() ? nullptr : &header);
  const std::string rpc(method.substr(method.rfind('/') + 1));
  if (!principal.ok()) {
    spdlog::warn("event=auth_refused rpc={} peer=\"{}\" code={} reason=\"{}\"", rpc, EscapeUntrusted(context->peer()),
                 absl::StatusCodeToString(principal.status().code()),
                 EscapeUntrusted(std::string(principal.status().message())));
    return ToGrpc(principal.status());
  }
  absl::Status allowed = AuthorizeMethod(*principal, method);
  if (allowed.ok()) allowed = CheckObject(*principal, method, object);
  const MethodRule* rule = FindRule(method);
  if (!allowed.ok()) {
    spdlog::warn("event=audit token=\"{}\" role={} rpc={} object=\"{}\" outcome={} reason=\"{}\"", principal->name,
                 RoleName(principal->role), rpc, EscapeUntrusted(object), absl::StatusCodeToString(allowed.code()),
                 EscapeUntrusted(std::string(allowed.message())));
    return ToGrpc(allowed);
  }
  grpc::Status status;
  {
    CallPrincipals::Scope scope(principals_, context, *principal);
    status = handler(*principal);
  }
  if (rule == nullptr || rule->changes_state) {
    const std::string what = describe ? describe() : object;
    spdlog::info("event=audit token=\"{}\" role={} rpc={} object=\"{}\" outcome={}", principal->name,
                 RoleName(principal->role), rpc, EscapeUntrusted(what),
                 absl::StatusCodeToString(static_cast<absl::StatusCode>(status.error_code())));
  }
  return status;
}

absl::Status AccessGuard::CheckObject(const Principal& principal, std::string_view method, const std::string& object) {
  const MethodRule* rule = FindRule(method);
  if (principal.role == Role::kAdmin || rule == nullptr) return absl::OkStatus();
  switch (rule->check) {
    case ObjectCheck::kNone:
      return absl::OkStatus();
    case ObjectCheck::kOwnJob: {
      auto owner = scheduler_->JobOwner(object);
      // An unknown or empty id: the handler answers NOT_FOUND /
      // INVALID_ARGUMENT as it always did.
      if (!owner.ok())
        return absl::IsNotFound(owner.status()) || absl::IsInvalidArgument(owner.status()) ? absl::OkStatus()
                                                                                           : owner.status();
      if (*owner == principal.name) return absl::OkStatus();
      return absl::PermissionDeniedError(absl::StrCat("job_id: job ", object, " was not submitted by token '",
                                                      principal.name, "'; only its submitter or an admin may see it"));
    }
    case ObjectCheck::kOwnLease: {
      auto holder = scheduler_->JobLeaseHolder(object);
      // Unknown ids and ended leases: the handler answers as it always did.
      if (!holder.ok() || holder->empty() || *holder == principal.name) {
        return holder.ok() || absl::IsNotFound(holder.status()) || absl::IsInvalidArgument(holder.status())
                   ? absl::OkStatus()
                   : holder.status();
      }
      return absl::PermissionDeniedError(absl::StrCat("job_id: job ", object, " is leased by another worker token, not '",
                                                      principal.name, "'"));
    }
    case ObjectCheck::kReadableBlob: {
      if (principal.role == Role::kWorker) {
        auto held = scheduler_->IsInputOfLeasedJob(principal.name, object);
        if (!held.ok()) return held.status();
        if (*held) return absl::OkStatus();
        return absl::PermissionDeniedError(absl::StrCat("digest: blob ", object.substr(0, 64),
                                                        " is not an input of a job token '", principal.name,
                                                        "' holds; workers read the inputs of their leased jobs only"));
      }
      auto result = scheduler_->IsResultBlob(object);
      if (!result.ok()) return result.status();
      if (*result) return absl::OkStatus();
      return absl::PermissionDeniedError(
          absl::StrCat("digest: blob ", object.substr(0, 64), " is not part of a baked result; role ",
                       std::string(RoleName(principal.role)), " may read result blobs only"));
    }
  }
  return absl::OkStatus();
}

absl::Status AccessGuard::AuthorizeObject(const Principal& principal, std::string_view method,
                                          const std::string& object, std::string_view field) {
  if (authenticator_ == nullptr) return absl::OkStatus();
  absl::Status allowed = CheckObject(principal, method, object);
  if (allowed.ok()) return allowed;
  const std::string rpc(method.substr(method.rfind('/') + 1));
  spdlog::warn("event=audit token=\"{}\" role={} rpc={} object=\"{}\" outcome={} reason=\"{}\"", principal.name,
               RoleName(principal.role), rpc, EscapeUntrusted(object), absl::StatusCodeToString(allowed.code()),
               EscapeUntrusted(std::string(allowed.message())));
  // The check names its one object "digest:"; here the caller's field does.
  absl::string_view reason = allowed.message();
  absl::ConsumePrefix(&reason, "digest: ");
  return absl::Status(allowed.code(), absl::StrCat(std::string(field), ": ", reason));
}

absl::Status AccessGuard::CheckSubmitQuota(const Principal& principal) {
  if (quotas_ == nullptr || principal.role == Role::kAdmin) return absl::OkStatus();
  auto pending = scheduler_->CountPendingOwnedBy(principal.name);
  if (!pending.ok()) return pending.status();
  return quotas_->CheckSubmit(principal.name, *pending);
}

void AccessGuard::RecordBake(const Principal& principal) {
  if (quotas_ != nullptr && principal.role != Role::kAdmin) quotas_->RecordBake(principal.name);
}

absl::Status AccessGuard::CheckUploadQuota(const Principal& principal) {
  if (quotas_ == nullptr || principal.role == Role::kAdmin) return absl::OkStatus();
  return quotas_->CheckUpload(principal.name);
}

void AccessGuard::RecordUpload(const Principal& principal, int64_t bytes) {
  if (quotas_ != nullptr && principal.role != Role::kAdmin) quotas_->RecordUpload(principal.name, bytes);
}

// ---- AssetService ----

grpc::Status AuthorizedAssetService::FindMissingBlobs(grpc::ServerContext* context,
                                                      const v1::FindMissingBlobsRequest* request,
                                                      v1::FindMissingBlobsResponse* response) {
  return guard_->Run(context, Method(kAsset, "FindMissingBlobs"), "",
                     [&](const Principal&) { return inner_->FindMissingBlobs(context, request, response); });
}

grpc::Status AuthorizedAssetService::UploadBlob(grpc::ServerContext* context,
                                                grpc::ServerReader<v1::UploadBlobRequest>* reader,
                                                v1::UploadBlobResponse* response) {
  return guard_->Run(
      context, Method(kAsset, "UploadBlob"), "",
      [&](const Principal& principal) {
        if (auto quota = guard_->CheckUploadQuota(principal); !quota.ok()) return ToGrpc(quota, context);
        grpc::Status status = inner_->UploadBlob(context, reader, response);
        if (status.ok() && !response->already_present())
          guard_->RecordUpload(principal, response->digest().size_bytes());
        return status;
      },
      [&] { return response->digest().hash(); });
}

// UploadBlob's rule for the whole batch: its roles, and the token's upload
// quota checked once before the first blob (so a batch may pass the limit
// by at most its 4 MiB, as an UploadBlob may by its one blob) and charged
// the bytes of the blobs the batch stored. The request is checked whole
// first, so a forged batch costs no ledger read. One audit line a call.
grpc::Status AuthorizedAssetService::BatchUpdateBlobs(grpc::ServerContext* context,
                                                      const v1::BatchUpdateBlobsRequest* request,
                                                      v1::BatchUpdateBlobsResponse* response) {
  return guard_->Run(
      context, Method(kAsset, "BatchUpdateBlobs"), "",
      [&](const Principal& principal) {
        if (absl::Status s = ValidateBatchUpdateRequest(*request); !s.ok()) return ToGrpc(s);
        if (auto quota = guard_->CheckUploadQuota(principal); !quota.ok()) return ToGrpc(quota, context);
        grpc::Status status = inner_->BatchUpdateBlobs(context, request, response);
        int64_t stored = 0;
        for (const v1::BatchUpdateBlobsResponse::Response& blob : response->responses()) {
          if (blob.code() == 0 && !blob.already_present()) stored += blob.digest().size_bytes();
        }
        if (stored > 0) guard_->RecordUpload(principal, stored);
        return status;
      },
      [&] {
        int present = 0, refused = 0;
        for (const v1::BatchUpdateBlobsResponse::Response& blob : response->responses()) {
          present += blob.code() == 0 && blob.already_present();
          refused += blob.code() != 0;
        }
        return absl::StrCat("blobs=", response->responses_size(), " present=", present, " refused=", refused);
      });
}

grpc::Status AuthorizedAssetService::QueryUpload(grpc::ServerContext* context,
                                                 const v1::QueryUploadRequest* request,
                                                 v1::QueryUploadResponse* response) {
  return guard_->Run(context, Method(kAsset, "QueryUpload"), "",
                     [&](const Principal&) { return inner_->QueryUpload(context, request, response); });
}

grpc::Status AuthorizedAssetService::ReadBlob(grpc::ServerContext* context, const v1::ReadBlobRequest* request,
                                              grpc::ServerWriter<v1::ReadBlobResponse>* writer) {
  return guard_->Run(context, Method(kAsset, "ReadBlob"), request->digest().hash(),
                     [&](const Principal&) { return inner_->ReadBlob(context, request, writer); });
}

// The request is checked whole first (its size, every digest's form), so a
// forged batch costs no store lookups; then every digest under ReadBlob's
// rule: a reader reads result blobs only, a worker its job's inputs.
grpc::Status AuthorizedAssetService::BatchReadBlobs(grpc::ServerContext* context,
                                                    const v1::BatchReadBlobsRequest* request,
                                                    v1::BatchReadBlobsResponse* response) {
  return guard_->Run(context, Method(kAsset, "BatchReadBlobs"), "", [&](const Principal& principal) {
    if (absl::Status s = ValidateBatchReadRequest(*request); !s.ok()) return ToGrpc(s);
    const std::string read_blob = Method(kAsset, "ReadBlob");
    for (int i = 0; i < request->digests_size(); ++i) {
      absl::Status allowed =
          guard_->AuthorizeObject(principal, read_blob, request->digests(i).hash(), absl::StrCat("digests[", i, "]"));
      if (!allowed.ok()) return ToGrpc(allowed);
    }
    return inner_->BatchReadBlobs(context, request, response);
  });
}

grpc::Status AuthorizedAssetService::GetResult(grpc::ServerContext* context, const v1::GetResultRequest* request,
                                               v1::Manifest* response) {
  return guard_->Run(context, Method(kAsset, "GetResult"), request->cache_key(),
                     [&](const Principal&) { return inner_->GetResult(context, request, response); });
}

grpc::Status AuthorizedAssetService::PinResult(grpc::ServerContext* context, const v1::PinResultRequest* request,
                                               v1::PinResultResponse* response) {
  return guard_->Run(context, Method(kAsset, "PinResult"), request->cache_key(),
                     [&](const Principal&) { return inner_->PinResult(context, request, response); });
}

// ---- BakeService ----

grpc::Status AuthorizedBakeService::SubmitBake(grpc::ServerContext* context, const v1::SubmitBakeRequest* request,
                                               v1::SubmitBakeResponse* response) {
  return guard_->Run(
      context, Method(kBake, "SubmitBake"), "",
      [&](const Principal& principal) {
        if (auto quota = guard_->CheckSubmitQuota(principal); !quota.ok()) return ToGrpc(quota, context);
        grpc::Status status = inner_->SubmitBake(context, request, response);
        if (status.ok() && !response->cached()) guard_->RecordBake(principal);
        return status;
      },
      [&] { return absl::StrCat(response->job_id(), " cache_key=", response->cache_key()); });
}

grpc::Status AuthorizedBakeService::LookupBake(grpc::ServerContext* context, const v1::SubmitBakeRequest* request,
                                               v1::LookupBakeResponse* response) {
  return guard_->Run(context, Method(kBake, "LookupBake"), "",
                     [&](const Principal&) { return inner_->LookupBake(context, request, response); });
}

grpc::Status AuthorizedBakeService::WatchJob(grpc::ServerContext* context, const v1::WatchJobRequest* request,
                                             grpc::ServerWriter<v1::Job>* writer) {
  return guard_->Run(context, Method(kBake, "WatchJob"), request->job_id(),
                     [&](const Principal&) { return inner_->WatchJob(context, request, writer); });
}

grpc::Status AuthorizedBakeService::GetJob(grpc::ServerContext* context, const v1::GetJobRequest* request,
                                           v1::Job* response) {
  return guard_->Run(context, Method(kBake, "GetJob"), request->job_id(),
                     [&](const Principal&) { return inner_->GetJob(context, request, response); });
}

grpc::Status AuthorizedBakeService::CancelJob(grpc::ServerContext* context, const v1::CancelJobRequest* request,
                                              v1::Job* response) {
  return guard_->Run(context, Method(kBake, "CancelJob"), request->job_id(),
                     [&](const Principal&) { return inner_->CancelJob(context, request, response); });
}

// ---- WorkerService ----

grpc::Status AuthorizedWorkerService::LeaseJob(grpc::ServerContext* context, const v1::LeaseJobRequest* request,
                                               v1::LeaseJobResponse* response) {
  return guard_->Run(
      context, Method(kWorker, "LeaseJob"), "",
      [&](const Principal&) { return inner_->LeaseJob(context, request, response); },
      [&] { return response->has_job() ? response->job().job_id() : std::string("none"); });
}

grpc::Status AuthorizedWorkerService::ReportProgress(grpc::ServerContext* context,
                                                     const v1::ReportProgressRequest* request,
                                                     v1::ReportProgressResponse* response) {
  return guard_->Run(context, Method(kWorker, "ReportProgress"), request->job_id(),
                     [&](const Principal&) { return inner_->ReportProgress(context, request, response); });
}

grpc::Status AuthorizedWorkerService::CompleteJob(grpc::ServerContext* context, const v1::CompleteJobRequest* request,
                                                  v1::CompleteJobResponse* response) {
  return guard_->Run(
      context, Method(kWorker, "CompleteJob"), request->job_id(),
      [&](const Principal&) { return inner_->CompleteJob(context, request, response); },
      [&] { return absl::StrCat(request->job_id(), " cache_key=", request->result().cache_key()); });
}

grpc::Status AuthorizedWorkerService::FailJob(grpc::ServerContext* context, const v1::FailJobRequest* request,
                                              v1::FailJobResponse* response) {
  return guard_->Run(context, Method(kWorker, "FailJob"), request->job_id(),
                     [&](const Principal&) { return inner_->FailJob(context, request, response); });
}

grpc::Status AuthorizedWorkerService::ReleaseJob(grpc::ServerContext* context, const v1::ReleaseJobRequest* request,
                                                 v1::ReleaseJobResponse* response) {
  return guard_->Run(context, Method(kWorker, "ReleaseJob"), request->job_id(),
                     [&](const Principal&) { return inner_->ReleaseJob(context, request, response); });
}

// ---- AdminService ----

grpc::Status AuthorizedAdminService::PurgeWorkerResults(grpc::ServerContext* context,
                                                        const v1::PurgeWorkerResultsRequest* request,
                                                        v1::PurgeWorkerResultsResponse* response) {
  return guard_->Run(
      context, Method(kAdmin, "PurgeWorkerResults"), request->worker(),
      [&](const Principal&) { return inner_->PurgeWorkerResults(context, request, response); },
      [&] {
        return absl::StrCat("worker=", request->worker(), " results=", response->cache_keys_size(),
                            " blobs_removed=", response->blobs_removed());
      });
}

}  // namespace impostor
