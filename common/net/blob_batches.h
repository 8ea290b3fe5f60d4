// Packs blobs into batch calls (BatchReadBlobs, BatchUpdateBlobs) within a
// call's limits (batch_read.h). A pure function, shared by the SDK's reads
// and the worker's result upload.
#ifndef IMPOSTOR_COMMON_NET_BLOB_BATCHES_H_
#define IMPOSTOR_COMMON_NET_BLOB_BATCHES_H_

#include <cstddef>
#include <cstdint>
#include <vector>

namespace impostor {

// Splits blobs of `sizes` bytes (each >= 0 and at most `max_bytes`) into
// batches of at most `max_blobs` blobs and `max_bytes` bytes together,
// keeping their order: each batch is the indices into `sizes` of its
// blobs. Greedy: a batch is closed when the next blob does not fit.
std::vector<std::vector<size_t>> PackBatchesBySize(const std::vector<int64_t>& sizes, int max_blobs,
                                                   int64_t max_bytes);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_NET_BLOB_BATCHES_H_
