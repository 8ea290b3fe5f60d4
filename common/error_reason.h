// Why the server refused a call, as a stable word a program can act on
// without parsing the message, which is for people and may be reworded.
// Inside the server the word rides on the absl::Status as a payload; at the
// service edge ToGrpc (server/rpc/grpc_status.h) sends it as the trailing
// metadata `impostor-error-reason`, where every gRPC client can read it
// (grpcurl prints it too). The C++ SDK puts it in RpcErrorInfo::reason, the
// Python client in ImpostorError.reason. The words are listed here, in the
// proto comments of the calls that send them and in README.md (Quotas); a
// word, once sent, keeps its meaning.
#ifndef IMPOSTOR_COMMON_ERROR_REASON_H_
#define IMPOSTOR_COMMON_ERROR_REASON_H_

#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/strings/cord.h"

namespace impostor {

inline constexpr char kErrorReasonMetadataKey[] = "impostor-error-reason";

namespace error_reason {
// RESOURCE_EXHAUSTED from SubmitBake: frees up as jobs finish.
inline constexpr char kTokenPendingJobs[] = "TOKEN_PENDING_JOBS";    // this token's queued + running jobs
inline constexpr char kClientPendingJobs[] = "CLIENT_PENDING_JOBS";  // this client id's (within its token)
// RESOURCE_EXHAUSTED from SubmitBake: frees up with time.
inline constexpr char kFarmPendingJobs[] = "FARM_PENDING_JOBS";        // the whole farm's queue
inline constexpr char kTokenBakesPerHour[] = "TOKEN_BAKES_PER_HOUR";  // a sliding one-hour window
// RESOURCE_EXHAUSTED from UploadBlob and BatchUpdateBlobs: a sliding
// 24-hour window.
inline constexpr char kTokenUploadBytesPerDay[] = "TOKEN_UPLOAD_BYTES_PER_DAY";
// RESOURCE_EXHAUSTED from UploadBlob, and a BatchUpdateBlobs blob's own
// code (its reason field): the server's blob store has no space (disk or
// quota full). The farm's state, not the blob's: writes succeed
// again by themselves once space is freed, so a worker waits and retries
// its result upload as through an outage (worker/worker_calls.cc).
inline constexpr char kStoreFull[] = "STORE_FULL";
// RESOURCE_EXHAUSTED from any call that writes the server's database (jobs,
// tokens, quota ledger: SubmitBake, LeaseJob, ReportProgress, CompleteJob,
// FailJob, ReleaseJob, ...): the disk (or quota) under it has no space,
// SQLite's files in --data or PostgreSQL's disk (SQLSTATE 53100). The
// farm's state, not the request's: nothing was written, and the same call
// succeeds once space is freed, so a worker keeps its lease and retries
// CompleteJob, FailJob and ReleaseJob as through an outage
// (worker/worker_calls.cc); a client may wait and call again.
inline constexpr char kDatabaseFull[] = "DATABASE_FULL";
// FAILED_PRECONDITION from SubmitBake: one of the mesh's blobs is not in the
// store (never uploaded, or evicted since the upload): upload it, submit again.
inline constexpr char kInputBlobMissing[] = "INPUT_BLOB_MISSING";
// RESOURCE_EXHAUSTED as a job's error: no worker the server heard from could
// bake it (too little memory, no KTX2 encoder) for --unplaceable-timeout-
// seconds; the message names what it needs and the most any worker had.
// Add a worker that can, or ask for less (e.g. a lower --resolution).
inline constexpr char kUnplaceable[] = "UNPLACEABLE";
}  // namespace error_reason

namespace internal {
inline constexpr char kErrorReasonPayload[] = "type.impostor.dev/error_reason";
}  // namespace internal

// `status` with `reason` attached (no-op on OK).
inline absl::Status WithErrorReason(absl::Status status, std::string_view reason) {
  if (!status.ok()) status.SetPayload(internal::kErrorReasonPayload, absl::Cord(std::string(reason)));
  return status;
}

// The reason attached to `status`, or "" when none is.
inline std::string ErrorReasonOf(const absl::Status& status) {
  auto reason = status.GetPayload(internal::kErrorReasonPayload);  // absl::optional in Debian's abseil
  return reason.has_value() ? std::string(*reason) : std::string();
}

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_ERROR_REASON_H_
