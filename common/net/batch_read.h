// The batch calls' limits (proto/impostor/v1/asset_service.proto:
// BatchReadBlobs, BatchUpdateBlobs), shared by the server that enforces
// them and the clients and workers that pack batches (blob_batches.h).
#ifndef IMPOSTOR_COMMON_NET_BATCH_READ_H_
#define IMPOSTOR_COMMON_NET_BATCH_READ_H_

#include <cstdint>

namespace impostor {

// Digests per call, and their sizes added up: what one response may hold
// (a server answers many such calls at once, each held in memory whole).
inline constexpr int kMaxBatchReadDigests = 1'000;
inline constexpr int64_t kMaxBatchReadBytes = int64_t{4} << 20;

// Clients batch blobs up to this size and stream larger ones (ReadBlob):
// a large blob gains nothing from sharing a round trip and would hold a
// batch's other blobs back until its last byte.
inline constexpr int64_t kBatchReadBlobMaxBytes = int64_t{1} << 20;

// BatchUpdateBlobs: the same limits on the request, which carries the
// bytes and is held whole while each blob is stored (the server takes
// messages of up to 16 MiB, so a full batch and its digests fit), and the
// same size of blob worth batching; larger ones are streamed (UploadBlob).
inline constexpr int kMaxBatchUpdateBlobs = kMaxBatchReadDigests;
inline constexpr int64_t kMaxBatchUpdateBytes = kMaxBatchReadBytes;
inline constexpr int64_t kBatchUpdateBlobMaxBytes = kBatchReadBlobMaxBytes;

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_NET_BATCH_READ_H_
