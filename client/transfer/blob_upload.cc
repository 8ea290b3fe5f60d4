#include "client/transfer/blob_upload.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <string>

#include "absl/strings/str_cat.h"
#include "client/base/sdk_log.h"

namespace impostor::sdk {
namespace {

// One stream, from the file's byte `offset`.
absl::Status UploadOnce(Transport& transport, const std::filesystem::path& path, const v1::Digest& digest,
                        int64_t offset, const CancelSource* cancel) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::InternalError(absl::StrCat("cannot open ", path.string(), ": ", std::strerror(errno)));
  if (offset > 0 && !in.seekg(offset)) {
    return absl::InternalError(absl::StrCat("cannot seek to byte ", offset, " of ", path.string()));
  }
  Transport::ChunkSource next = [&](std::string* data) -> absl::StatusOr<bool> {
    data->resize(kUploadChunkBytes);
    in.read(data->data(), static_cast<std::streamsize>(data->size()));
    if (in.bad()) return absl::InternalError(absl::StrCat("read error on ", path.string()));
    data->resize(static_cast<size_t>(in.gcount()));
    return !data->empty();
  };
  absl::StatusOr<v1::UploadBlobResponse> response = transport.UploadBlob(digest, next, cancel, offset);
  if (!response.ok()) return response.status();
  if (response->already_present()) SdkLog().debug("{} was already in the store", path.string());
  return absl::OkStatus();
}

// Where the next stream starts: the bytes the server kept of an earlier
// one, or -1 when the server has the whole blob. A failed question (a
// server older than QueryUpload: UNIMPLEMENTED) is answered 0: start over.
int64_t ResumeOffset(Transport& transport, const v1::Digest& digest, const CancelSource* cancel) {
  absl::StatusOr<v1::QueryUploadResponse> held = transport.QueryUpload(digest, cancel);
  if (!held.ok()) {
    SdkLog().debug("QueryUpload for {} failed: {}; uploading from the first byte", digest.hash(),
                   held.status().ToString());
    return 0;
  }
  if (held->complete()) return -1;
  const int64_t kept = held->committed_bytes();
  return kept > 0 && kept < digest.size_bytes() ? kept : 0;
}

}  // namespace

absl::Status UploadBlobFile(Transport& transport, const std::filesystem::path& path, const v1::Digest& digest,
                            const CancelSource* cancel) {
  RetryPolicy retry = transport.NewRetryPolicy(cancel);
  // A blob of one message has nothing worth resuming: no question first.
  bool ask = digest.size_bytes() > static_cast<int64_t>(kUploadChunkBytes);
  int64_t resumed_at = 0;  // where the last stream started
  int moved_kept = 0;      // FAILED_PRECONDITIONs in a row: the kept partial changed under us
  while (true) {
    int64_t offset = 0;
    if (ask) {
      offset = ResumeOffset(transport, digest, cancel);
      if (cancel != nullptr && cancel->cancelled()) return cancel->error();
      if (offset < 0) {
        SdkLog().debug("{} is in the store already", path.string());
        return absl::OkStatus();
      }
      // The server holds more than the last stream started from: it moved.
      if (offset > resumed_at) retry.MadeProgress();
      if (offset > 0) SdkLog().debug("resuming the upload of {} at byte {}", path.string(), offset);
    }
    resumed_at = offset;
    absl::Status status = UploadOnce(transport, path, digest, offset, cancel);
    if (status.ok()) return status;
    if (cancel != nullptr && cancel->cancelled()) return cancel->error();
    // The kept partial is not where the question said (another stream of
    // the blob moved it, or it expired): ask again, a few times, at once.
    if (status.code() == absl::StatusCode::kFailedPrecondition && offset > 0 && ++moved_kept <= 3) {
      ask = true;
      continue;
    }
    moved_kept = 0;
    if (!retry.ShouldRetry(status)) return retry.cancelled() ? cancel->error() : status;
    SdkLog().debug("upload of {} failed ({} in a row): {}; resuming it", path.string(), retry.failures(),
                   status.ToString());
    ask = true;
  }
}

}  // namespace impostor::sdk
