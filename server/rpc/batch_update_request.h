// BatchUpdateBlobs' request checks (proto/impostor/v1/asset_service.proto),
// run before anything is stored: by the access guard before it checks the
// token's upload quota, and by the service itself.
#ifndef IMPOSTOR_SERVER_RPC_BATCH_UPDATE_REQUEST_H_
#define IMPOSTOR_SERVER_RPC_BATCH_UPDATE_REQUEST_H_

#include "absl/status/status.h"
#include "impostor/v1/asset_service.pb.h"

namespace impostor {

// INVALID_ARGUMENT naming the field and the limit: over kMaxBatchUpdateBlobs
// blobs, a missing or malformed digest (by position: requests[i].digest),
// or data that adds up to over kMaxBatchUpdateBytes (common/net/batch_read.h).
// Data that does not match its digest is not checked here: that is the
// blob's own refusal, answered in its slot.
absl::Status ValidateBatchUpdateRequest(const v1::BatchUpdateBlobsRequest& request);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_RPC_BATCH_UPDATE_REQUEST_H_
