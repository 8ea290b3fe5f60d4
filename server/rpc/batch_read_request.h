// BatchReadBlobs' request checks (proto/impostor/v1/asset_service.proto),
// run before anything is read: by the access guard before it looks up the
// token's rights to each digest, and by the service itself.
#ifndef IMPOSTOR_SERVER_RPC_BATCH_READ_REQUEST_H_
#define IMPOSTOR_SERVER_RPC_BATCH_READ_REQUEST_H_

#include "absl/status/status.h"
#include "impostor/v1/asset_service.pb.h"

namespace impostor {

// INVALID_ARGUMENT naming the field and the limit: over kMaxBatchReadDigests
// digests, a malformed digest (by position), or sizes that add up to over
// kMaxBatchReadBytes (common/net/batch_read.h).
absl::Status ValidateBatchReadRequest(const v1::BatchReadBlobsRequest& request);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_RPC_BATCH_READ_REQUEST_H_
