#include "worker/result_batch_upload.h"

#include <algorithm>
#include <chrono>
#include <fstream>
#include <iterator>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "common/error_reason.h"
#include "worker/worker_rpc.h"

namespace impostor {
namespace {

absl::StatusOr<std::string> ReadWholeFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::InternalError(absl::StrCat("cannot open ", path.string()));
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) return absl::InternalError(absl::StrCat("read error on ", path.string()));
  return bytes;
}

// A status of code `code` (a gRPC code the server sent), naming `what`.
absl::Status StatusFrom(int code, std::string_view what, std::string_view message, std::string_view reason) {
  const auto known = code > 0 && code <= 16 ? static_cast<absl::StatusCode>(code) : absl::StatusCode::kUnknown;
  absl::Status status(known, absl::StrCat(std::string(what), ": ", std::string(message)));
  return reason.empty() ? status : WithErrorReason(std::move(status), reason);
}

}  // namespace

absl::Status UploadResultBatch(v1::AssetService::Stub& assets, const std::vector<ResultFile>& files,
                               std::vector<absl::Status>* each, const ResultUploadOptions& options) {
  each->clear();
  v1::BatchUpdateBlobsRequest request;
  int64_t bytes = 0;
  for (const ResultFile& file : files) {
    absl::StatusOr<std::string> data = ReadWholeFile(file.path);
    if (!data.ok()) return data.status();
    bytes += static_cast<int64_t>(data->size());
    v1::BatchUpdateBlobsRequest::Request* blob = request.add_requests();
    *blob->mutable_digest() = file.digest;
    blob->set_data(std::move(*data));
  }
  const int64_t chunk = static_cast<int64_t>(std::max<size_t>(options.chunk_bytes, 1));
  const int64_t messages = (bytes + chunk - 1) / chunk;
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + options.stall_limit * (1 + messages));
  const UploadCancel::Call registered(options.cancel, &ctx);
  v1::BatchUpdateBlobsResponse response;
  const grpc::Status s = assets.BatchUpdateBlobs(&ctx, request, &response);
  if (!s.ok()) {
    return StatusFrom(s.error_code(), "BatchUpdateBlobs", s.error_message(), worker_rpc::ServerErrorReason(ctx));
  }
  if (response.responses_size() != request.requests_size()) {
    return absl::InternalError(absl::StrCat("BatchUpdateBlobs: answered ", response.responses_size(),
                                            " blobs for the ", request.requests_size(), " sent"));
  }
  for (int i = 0; i < response.responses_size(); ++i) {
    const v1::BatchUpdateBlobsResponse::Response& blob = response.responses(i);
    const v1::Digest& sent = request.requests(i).digest();
    if (blob.digest().hash() != sent.hash() || blob.digest().size_bytes() != sent.size_bytes()) {
      each->clear();
      return absl::InternalError(absl::StrCat("BatchUpdateBlobs: blob ", i, " answered is ", blob.digest().hash(),
                                              "/", blob.digest().size_bytes(), ", not the ", sent.hash(), "/",
                                              sent.size_bytes(), " sent"));
    }
    each->push_back(blob.code() == 0 ? absl::OkStatus()
                                     : StatusFrom(blob.code(), "BatchUpdateBlobs", blob.message(), blob.reason()));
  }
  return absl::OkStatus();
}

}  // namespace impostor
