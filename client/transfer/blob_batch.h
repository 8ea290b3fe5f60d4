// Reads small blobs many to a round trip (AssetService.BatchReadBlobs) and
// checks each one as a ReadBlob download is checked: the answer's order and
// digests, the size, the SHA-256. A result's 36 view images, contact sheet
// and manifest are one call instead of 36 streams (issue 45).
#ifndef IMPOSTOR_CLIENT_TRANSFER_BLOB_BATCH_H_
#define IMPOSTOR_CLIENT_TRANSFER_BLOB_BATCH_H_

#include <cstddef>
#include <functional>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "client/transport/retry.h"
#include "client/transport/transport.h"
#include "impostor/v1/types.pb.h"

namespace impostor::sdk {

// True for a blob worth batching (at most kBatchReadBlobMaxBytes).
bool FitsBlobBatch(const v1::Digest& digest);

// Splits `digests` (each FitsBlobBatch) into batches within BatchReadBlobs'
// limits (common/net/batch_read.h), keeping their order: each batch is the
// indices into `digests` of its blobs.
std::vector<std::vector<size_t>> PackBlobBatches(const std::vector<v1::Digest>& digests);

// One BatchReadBlobs call for `digests` (one batch of PackBlobBatches),
// retried as the transport's unary calls are. `on_blob(i, bytes)` is called
// for each blob once its bytes are verified, in order; a non-OK status from
// it ends the batch and is returned as is (`*failed` untouched). Errors:
// UNIMPLEMENTED when the server predates the call (read the blobs with
// ReadBlob instead); a blob's own code (NOT_FOUND, DATA_LOSS, ...) and
// DATA_LOSS for an answer that does not match the request or bytes that do
// not verify, each naming the blob and with `*failed` (may be null) set to
// its index; the call's error otherwise. `cancel` as for DownloadBlob.
absl::Status ReadBlobBatch(Transport& transport, const std::vector<v1::Digest>& digests,
                           const std::function<absl::Status(size_t i, std::string_view bytes)>& on_blob,
                           size_t* failed = nullptr, const CancelSource* cancel = nullptr);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSFER_BLOB_BATCH_H_
