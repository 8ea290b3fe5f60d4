#include "server/rpc/batch_update_request.h"

#include "absl/strings/str_cat.h"
#include "common/net/batch_read.h"
#include "common/util/sha256.h"

namespace impostor {

absl::Status ValidateBatchUpdateRequest(const v1::BatchUpdateBlobsRequest& request) {
  if (request.requests_size() > kMaxBatchUpdateBlobs) {
    return absl::InvalidArgumentError(absl::StrCat("requests: ", request.requests_size(),
                                                   " blobs is over the limit of ", kMaxBatchUpdateBlobs));
  }
  int64_t total = 0;
  for (int i = 0; i < request.requests_size(); ++i) {
    const v1::BatchUpdateBlobsRequest::Request& r = request.requests(i);
    const std::string field = absl::StrCat("requests[", i, "].digest");
    if (!r.has_digest()) return absl::InvalidArgumentError(absl::StrCat(field, ": required"));
    if (absl::Status s = ValidateDigest(field, r.digest().hash(), r.digest().size_bytes()); !s.ok()) return s;
    const int64_t size = static_cast<int64_t>(r.data().size());
    if (size > kMaxBatchUpdateBytes - total) {
      return absl::InvalidArgumentError(absl::StrCat("requests[", i, "].data: ", size, " bytes after ", total,
                                                     " takes the batch over its limit of ", kMaxBatchUpdateBytes,
                                                     " bytes (4 MiB); upload larger blobs with UploadBlob"));
    }
    total += size;
  }
  return absl::OkStatus();
}

}  // namespace impostor
