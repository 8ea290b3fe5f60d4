// The worker's upload of a result's small files many to a round trip
// (AssetService.BatchUpdateBlobs) over a synchronous stub: one call for a
// result's 36 view images, contact sheet and manifest instead of a stream
// each. Used by UploadResultFiles (result_files_upload.h); no retrying here.
//
// Thread-safety: a free function; concurrent calls share nothing.
#ifndef IMPOSTOR_WORKER_RESULT_BATCH_UPLOAD_H_
#define IMPOSTOR_WORKER_RESULT_BATCH_UPLOAD_H_

#include <filesystem>
#include <vector>

#include "absl/status/status.h"
#include "impostor/v1/asset_service.grpc.pb.h"
#include "worker/result_upload.h"

namespace impostor {

// A file of a result and the digest its bytes hash to.
struct ResultFile {
  std::filesystem::path path;
  v1::Digest digest;
};

// Sends `files` (one batch of PackBatchesBySize within BatchUpdateBlobs'
// limits, common/net/batch_read.h) in one BatchUpdateBlobs call. Its
// deadline gives the request the time UploadResultFile's watchdog gives
// that many bytes in options.chunk_bytes messages (stall_limit per message,
// plus one), so a slow link is not cut for being slow.
//
// OK when the server answered every file: `*each` (not null) then holds
// each file's outcome in order, OK (stored, or present already) or the
// server's refusal of that blob (its message names requests[i]), with its
// error reason (STORE_FULL) on the status. Otherwise the call's error and `*each` is
// empty: UNIMPLEMENTED from a server older than the call (upload the files
// with UploadResultFile instead); the server's refusal of the whole request
// with its error reason (TOKEN_UPLOAD_BYTES_PER_DAY); UNAVAILABLE or
// DEADLINE_EXCEEDED; INTERNAL naming a file that cannot be read, or for an
// answer that does not match the request.
absl::Status UploadResultBatch(v1::AssetService::Stub& assets, const std::vector<ResultFile>& files,
                               std::vector<absl::Status>* each, const ResultUploadOptions& options = {});

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_RESULT_BATCH_UPLOAD_H_
