#include "server/rpc/batch_read_request.h"

#include "absl/strings/str_cat.h"
#include "common/net/batch_read.h"
#include "common/util/sha256.h"

namespace impostor {

absl::Status ValidateBatchReadRequest(const v1::BatchReadBlobsRequest& request) {
  if (request.digests_size() > kMaxBatchReadDigests) {
    return absl::InvalidArgumentError(absl::StrCat("digests: ", request.digests_size(),
                                                   " digests is over the limit of ", kMaxBatchReadDigests));
  }
  int64_t total = 0;
  for (int i = 0; i < request.digests_size(); ++i) {
    const v1::Digest& d = request.digests(i);
    if (absl::Status s = ValidateDigest(absl::StrCat("digests[", i, "]"), d.hash(), d.size_bytes()); !s.ok()) {
      return s;
    }
    // Compared before adding: a forged size_bytes near INT64_MAX must not wrap.
    if (d.size_bytes() > kMaxBatchReadBytes - total) {
      return absl::InvalidArgumentError(absl::StrCat("digests[", i, "].size_bytes: ", d.size_bytes(),
                                                     " bytes after ", total, " takes the batch over its limit of ",
                                                     kMaxBatchReadBytes, " bytes (4 MiB); read larger blobs with ReadBlob"));
    }
    total += d.size_bytes();
  }
  return absl::OkStatus();
}

}  // namespace impostor
