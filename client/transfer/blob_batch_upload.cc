#include "client/transfer/blob_batch_upload.h"

#include <fstream>
#include <iterator>
#include <string>

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"
#include "client/base/sdk_log.h"
#include "client/transfer/blob_upload.h"
#include "common/net/batch_read.h"
#include "common/net/blob_batches.h"

namespace impostor::sdk {
namespace {

// A batch's deadline counts its bytes in UploadBlob's messages.
static_assert(Transport::kBatchUpdateMessageBytes == static_cast<int64_t>(kUploadChunkBytes));

bool FitsBlobUpdate(const v1::Digest& digest) {
  return digest.size_bytes() >= 0 && digest.size_bytes() <= kUploadBatchMaxBytes;
}

// The whole file, or nothing when it cannot be read: the stream's try then
// says why, naming the file.
bool ReadWholeFile(const std::filesystem::path& path, std::string* bytes) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  bytes->assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  return !in.bad();
}

// One BatchUpdateBlobs call for the blobs `batch` (indices into `blobs`):
// sets stored[i] for each one the server holds now, refused[i] to the code
// of each one it refused in its slot. OK also when the server refused the
// whole request for its blobs (they go to the stream); UNIMPLEMENTED from an
// older server; otherwise the call's error that ends the upload.
absl::Status SendBatch(Transport& transport, const std::vector<LocalBlob>& blobs, const std::vector<size_t>& batch,
                       std::vector<char>& stored, std::vector<std::string>& refused, const CancelSource* cancel) {
  v1::BatchUpdateBlobsRequest request;
  std::vector<size_t> sent;  // indices into blobs, one per request entry
  for (size_t i : batch) {
    v1::BatchUpdateBlobsRequest::Request entry;
    if (!ReadWholeFile(blobs[i].path, entry.mutable_data())) continue;
    *entry.mutable_digest() = blobs[i].digest;
    *request.add_requests() = std::move(entry);
    sent.push_back(i);
  }
  if (sent.empty()) return absl::OkStatus();
  absl::StatusOr<v1::BatchUpdateBlobsResponse> response = transport.BatchUpdateBlobs(request, cancel);
  if (!response.ok()) {
    if (absl::IsUnimplemented(response.status()) || !IsRefusalOfTheBlob(response.status())) return response.status();
    SdkLog().info("{}; uploading its {} blobs one by one", response.status().ToString(), sent.size());
    return absl::OkStatus();
  }
  if (response->responses_size() != request.requests_size()) {
    SdkLog().warn("BatchUpdateBlobs from {} answered {} blobs for the {} sent; uploading them one by one",
                  transport.server(), response->responses_size(), request.requests_size());
    return absl::OkStatus();
  }
  size_t refusals = 0;
  std::string first;
  for (int k = 0; k < response->responses_size(); ++k) {
    const v1::BatchUpdateBlobsResponse::Response& answer = response->responses(k);
    const size_t i = sent[static_cast<size_t>(k)];
    const v1::Digest& want = blobs[i].digest;
    // An answer for another blob says nothing of this one: the stream asks again.
    if (answer.digest().hash() != want.hash() || answer.digest().size_bytes() != want.size_bytes()) continue;
    if (answer.code() == 0) {
      stored[i] = 1;
      continue;
    }
    const auto code = answer.code() > 0 && answer.code() <= 16 ? static_cast<absl::StatusCode>(answer.code())
                                                               : absl::StatusCode::kUnknown;
    refused[i] = absl::StatusCodeToString(code);
    if (refusals++ == 0) {
      first = absl::StrCat(blobs[i].path.string(), ": ", refused[i], " ", answer.message());
    }
  }
  // One line a batch, however many of its blobs were refused (a full store
  // refuses them all).
  if (refusals > 0) {
    SdkLog().info("BatchUpdateBlobs to {} refused {} of {} blobs (first {}); uploading them one by one",
                  transport.server(), refusals, sent.size(), first);
  }
  return absl::OkStatus();
}

}  // namespace

bool IsRefusalOfTheBlob(const absl::Status& s) {
  return absl::IsResourceExhausted(s) || absl::IsInvalidArgument(s) || absl::IsFailedPrecondition(s) ||
         absl::IsDataLoss(s) || absl::IsNotFound(s);
}

absl::StatusOr<std::vector<absl::Status>> UploadBlobFiles(Transport& transport, const std::vector<LocalBlob>& blobs,
                                                          const CancelSource* cancel) {
  std::vector<absl::Status> out(blobs.size());
  std::vector<char> stored(blobs.size(), 0);
  std::vector<std::string> refused(blobs.size());  // the code a batch refused the blob with
  std::vector<size_t> small;
  std::vector<int64_t> small_sizes;
  for (size_t i = 0; i < blobs.size(); ++i) {
    if (!FitsBlobUpdate(blobs[i].digest)) continue;
    small.push_back(i);
    small_sizes.push_back(blobs[i].digest.size_bytes());
  }
  for (const std::vector<size_t>& packed : PackBatchesBySize(small_sizes, kMaxBatchUpdateBlobs, kUploadBatchMaxBytes)) {
    if (cancel != nullptr && cancel->cancelled()) return cancel->error();
    std::vector<size_t> batch;
    for (size_t k : packed) batch.push_back(small[k]);
    absl::Status s = SendBatch(transport, blobs, batch, stored, refused, cancel);
    if (absl::IsUnimplemented(s)) {
      SdkLog().debug("{} has no BatchUpdateBlobs ({}); uploading every blob with UploadBlob", transport.server(),
                     s.ToString());
      break;
    }
    if (!s.ok()) return s;
  }
  for (size_t i = 0; i < blobs.size(); ++i) {
    if (stored[i]) continue;
    if (cancel != nullptr && cancel->cancelled()) return cancel->error();
    absl::Status s = UploadBlobFile(transport, blobs[i].path, blobs[i].digest, cancel);
    if (s.ok()) continue;
    if (!IsRefusalOfTheBlob(s)) return s;
    if (!refused[i].empty()) {
      // Refused twice: both answers, and the payloads (the RPC, the server,
      // its error reason) of the last.
      absl::Status both(s.code(), absl::StrCat(s.message(), " (refused in its batch first: ", refused[i], ")"));
      s.ForEachPayload([&both](absl::string_view type_url, const absl::Cord& payload) {
        both.SetPayload(type_url, payload);
      });
      s = std::move(both);
    }
    out[i] = std::move(s);
  }
  return out;
}

}  // namespace impostor::sdk
