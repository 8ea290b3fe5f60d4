// Puts a model's files into the server's blob store: hashes every file, asks
// once which blobs the server lacks and uploads only those, as
// UploadBlobFiles does (blob_batch_upload.h): the small ones many to a
// BatchUpdateBlobs call, the large ones streamed (no overall deadline, only
// a stalled link ends a stream). Called by Client::SubmitBake on the
// caller's thread.
#ifndef IMPOSTOR_CLIENT_TRANSFER_MESH_UPLOAD_H_
#define IMPOSTOR_CLIENT_TRANSFER_MESH_UPLOAD_H_

#include <vector>

#include "absl/status/statusor.h"
#include "client/transfer/file_digest_memo.h"
#include "client/transfer/mesh_files.h"
#include "client/transport/retry.h"
#include "client/transport/transport.h"
#include "impostor/client.h"
#include "impostor/v1/types.pb.h"

namespace impostor::sdk {

struct UploadedMesh {
  v1::MeshInput mesh;  // entry and files with their digests, ready to submit
  UploadStats stats;
};

// `cancel` (may be null; must outlive the call): Cancel() from any thread
// ends the upload promptly with cancel->error() (CANCELLED), here and in
// UploadMeshes.
absl::StatusOr<UploadedMesh> UploadMesh(Transport& transport, const MeshFiles& files,
                                        const CancelSource* cancel = nullptr);

// The most digests one FindMissingBlobs may carry (AssetService's limit).
inline constexpr size_t kMaxFindMissingDigests = 10'000;

// UploadMesh for many models at once: one FindMissingBlobs for all of their
// blobs (one per kMaxFindMissingDigests distinct blobs), each missing blob
// uploaded once and counted in the stats of the first model that has it.
// A model whose files cannot be read, or one of whose blobs the server
// refused (RESOURCE_EXHAUSTED: its disk is full; INVALID_ARGUMENT: too
// large), gets its own error in the result and the others go on; the call
// fails as a whole only when FindMissingBlobs does or an upload fails for
// the caller or the link (UNAVAILABLE; DEADLINE_EXCEEDED: the link stalled;
// CANCELLED; UNAUTHENTICATED; PERMISSION_DENIED). A refusal names the file
// ("uploading <path>: ..."), here and in UploadMesh.
absl::StatusOr<std::vector<absl::StatusOr<UploadedMesh>>> UploadMeshes(Transport& transport,
                                                                      const std::vector<const MeshFiles*>& models,
                                                                      const CancelSource* cancel = nullptr);

// The MeshInput naming `files` with their digests, hashed locally and
// uploaded nowhere: what LookupBake needs. NOT_FOUND / INTERNAL naming the
// file on read errors.
absl::StatusOr<v1::MeshInput> HashMesh(const MeshFiles& files);
// The same, each file's digest taken from `memo` when it was hashed there
// already and has not changed since (UploadMeshes: one memo for the batch).
absl::StatusOr<v1::MeshInput> HashMesh(const MeshFiles& files, FileDigestMemo& memo);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSFER_MESH_UPLOAD_H_
