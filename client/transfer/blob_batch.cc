#include "client/transfer/blob_batch.h"

#include <string>

#include "absl/strings/str_cat.h"
#include "common/net/batch_read.h"
#include "common/net/blob_batches.h"
#include "common/util/sha256.h"

namespace impostor::sdk {

bool FitsBlobBatch(const v1::Digest& digest) {
  return digest.size_bytes() >= 0 && digest.size_bytes() <= kBatchReadBlobMaxBytes;
}

std::vector<std::vector<size_t>> PackBlobBatches(const std::vector<v1::Digest>& digests) {
  std::vector<int64_t> sizes;
  sizes.reserve(digests.size());
  for (const v1::Digest& digest : digests) sizes.push_back(digest.size_bytes());
  return PackBatchesBySize(sizes, kMaxBatchReadDigests, kMaxBatchReadBytes);
}

absl::Status ReadBlobBatch(Transport& transport, const std::vector<v1::Digest>& digests,
                           const std::function<absl::Status(size_t i, std::string_view bytes)>& on_blob,
                           size_t* failed, const CancelSource* cancel) {
  v1::BatchReadBlobsRequest request;
  for (const v1::Digest& digest : digests) *request.add_digests() = digest;
  absl::StatusOr<v1::BatchReadBlobsResponse> response = transport.BatchReadBlobs(request, cancel);
  if (!response.ok()) return response.status();
  const std::string from = absl::StrCat("BatchReadBlobs from ", transport.server());
  if (response->blobs_size() != request.digests_size()) {
    return absl::DataLossError(absl::StrCat(from, ": answered ", response->blobs_size(), " blobs for the ",
                                            request.digests_size(), " asked"));
  }
  for (int i = 0; i < response->blobs_size(); ++i) {
    const v1::BatchReadBlobsResponse::Blob& blob = response->blobs(i);
    const v1::Digest& want = request.digests(i);
    const std::string name = absl::StrCat(want.hash(), "/", want.size_bytes());
    auto fail = [&](absl::Status status) {
      if (failed != nullptr) *failed = static_cast<size_t>(i);
      return status;
    };
    if (blob.digest().hash() != want.hash() || blob.digest().size_bytes() != want.size_bytes()) {
      return fail(absl::DataLossError(absl::StrCat(from, ": blob ", i, " answered is ", blob.digest().hash(), "/",
                                                   blob.digest().size_bytes(), ", not the ", name, " asked")));
    }
    if (blob.code() != 0) {
      // The server's own words for this blob (NOT_FOUND, DATA_LOSS, ...).
      const auto code = blob.code() > 0 && blob.code() <= 16 ? static_cast<absl::StatusCode>(blob.code())
                                                             : absl::StatusCode::kUnknown;
      return fail(absl::Status(code, absl::StrCat(from, ": blob ", name, ": ", blob.message())));
    }
    if (static_cast<int64_t>(blob.data().size()) != want.size_bytes()) {
      return fail(absl::DataLossError(absl::StrCat(from, ": blob ", name, ": received ", blob.data().size(),
                                                   " bytes, its digest says ", want.size_bytes())));
    }
    Sha256 hash;
    hash.Update(blob.data());
    if (const std::string actual = hash.FinishHex(); actual != want.hash()) {
      return fail(absl::DataLossError(absl::StrCat(from, ": blob ", name, ": received bytes hash to ", actual)));
    }
    // The caller's own error (a full disk) names what it wrote: no index.
    if (absl::Status s = on_blob(static_cast<size_t>(i), blob.data()); !s.ok()) return s;
  }
  return absl::OkStatus();
}

}  // namespace impostor::sdk
