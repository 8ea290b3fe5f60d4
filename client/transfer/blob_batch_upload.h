// Stores local files as blobs, the small ones many to a round trip
// (AssetService.BatchUpdateBlobs) and the large ones streamed (UploadBlobFile,
// resumable): a model's .gltf, .bin and dozens of small textures cost one
// call instead of a stream each (issue 45). Used by UploadMesh and
// UploadMeshes (mesh_upload.h); runs on the caller's thread.
#ifndef IMPOSTOR_CLIENT_TRANSFER_BLOB_BATCH_UPLOAD_H_
#define IMPOSTOR_CLIENT_TRANSFER_BLOB_BATCH_UPLOAD_H_

#include <cstdint>
#include <filesystem>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "client/transfer/blob_upload.h"
#include "client/transport/retry.h"
#include "client/transport/transport.h"
#include "impostor/v1/types.pb.h"

namespace impostor::sdk {

// An SDK's BatchUpdateBlobs call carries at most one UploadBlob message's
// bytes (kUploadChunkBytes), blobs of at most that many each: the uplink may
// be an artist's slow one, and a call must cross it as soon as one message of
// a stream would. A 1 MiB call took 53 s at 20 KB/s, and the connection's
// keepalive gave up on it, its ping waiting behind the call's bytes
// (python/tests/test_slow_link.py). The worker, on a farm's own network,
// batches blobs of up to 1 MiB in calls of up to 4 MiB
// (worker/result_files_upload.h).
inline constexpr int64_t kUploadBatchMaxBytes = static_cast<int64_t>(kUploadChunkBytes);

// A local file and the digest its bytes hash to.
struct LocalBlob {
  std::filesystem::path path;
  v1::Digest digest;
};

// An upload error about the blob, not about the caller or the link: the
// server's disk is full (RESOURCE_EXHAUSTED), the blob is too large or its
// bytes do not match (INVALID_ARGUMENT), ... Only the models that use the
// blob fail of it.
bool IsRefusalOfTheBlob(const absl::Status& s);

// Puts every blob of `blobs` (distinct digests) into the server's store.
//  1. Those of at most kUploadBatchMaxBytes go in BatchUpdateBlobs calls of
//     at most kUploadBatchMaxBytes and kMaxBatchUpdateBlobs blobs
//     (PackBatchesBySize), in order. A server older than the call
//     (UNIMPLEMENTED) gets no further batch.
//  2. Every blob not stored by then, in order, through UploadBlobFile (with
//     its retries, resume and outage waits): the large ones, those of an
//     older server, those of a batch the server refused whole (a quota:
//     the stream gets the same answer, for that blob alone) or answered
//     amiss, and a blob the batch refused in its slot (a full store, a
//     mismatch): its one retry.
// Returns each blob's outcome in order: OK once the store holds it (stored,
// or present already), else its refusal (IsRefusalOfTheBlob) as
// UploadBlobFile said it; for a blob its batch refused too, the message adds
// that code. The call fails as a whole, at once, with the first error that
// is not a refusal of one blob (UNAVAILABLE, DEADLINE_EXCEEDED, CANCELLED,
// UNAUTHENTICATED, PERMISSION_DENIED; INTERNAL naming a file that cannot be
// read). `cancel` as for UploadBlobFile.
absl::StatusOr<std::vector<absl::Status>> UploadBlobFiles(Transport& transport, const std::vector<LocalBlob>& blobs,
                                                          const CancelSource* cancel = nullptr);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSFER_BLOB_BATCH_UPLOAD_H_
