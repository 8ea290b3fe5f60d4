// A result's files into the server's blob store: the small ones (at most
// kBatchUpdateBlobMaxBytes, common/net/batch_read.h) many to a
// BatchUpdateBlobs call, the large ones streamed (UploadBlob, resumable),
// several calls at a time. The worker loop (worker_calls.cc) supplies how a
// call reaches the farm and how one file is uploaded patiently; this file
// decides what goes in which call and what is tried again.
//
// Thread-safety: a free function; it runs its calls on threads of its own
// and joins them before it returns.
#ifndef IMPOSTOR_WORKER_RESULT_FILES_UPLOAD_H_
#define IMPOSTOR_WORKER_RESULT_FILES_UPLOAD_H_

#include <functional>
#include <vector>

#include "absl/status/status.h"
#include "impostor/v1/asset_service.grpc.pb.h"
#include "worker/result_batch_upload.h"
#include "worker/result_upload.h"

namespace impostor {

// How UploadResultFiles reaches the farm. Both may be called from several
// threads at once.
struct ResultUploadLink {
  // One attempt of `rpc` on the current server (the worker loop's
  // CallServer, which keeps the failover's books): returns its status.
  std::function<absl::Status(const std::function<absl::Status(v1::AssetService::Stub&)>& rpc)> call;
  // One file through UploadBlob, riding out outages and a full store
  // (the worker loop's UploadThroughOutage): its final status.
  std::function<absl::Status(const ResultFile& file)> upload_patiently;
};

// Uploads every file of `files`; OK once the store holds them all.
//  1. The small files in batches (PackBatchesBySize) and the large ones
//     streamed (UploadResultFile), `parallel` calls at a time, until a call
//     fails. A server older than BatchUpdateBlobs (UNIMPLEMENTED) gets the
//     files of that batch streamed, `parallel` at a time, after this pass.
//  2. Every file not stored after that (a call failed, or the batch refused
//     that one blob in its slot: a full store, a mismatch), one at a time,
//     in order, through link.upload_patiently: the one retry of a refused
//     blob, and the waits for a server or for space.
// Errors: the first error of step 2; for a file its batch refused too, the
// message names the file and both codes.
absl::Status UploadResultFiles(const std::vector<ResultFile>& files, const ResultUploadLink& link, int parallel,
                               const ResultUploadOptions& options = {});

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_RESULT_FILES_UPLOAD_H_
