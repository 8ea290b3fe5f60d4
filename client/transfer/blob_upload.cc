#include "client/transfer/blob_upload.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <string>

#include "absl/strings/str_cat.h"
#include "client/base/sdk_log.h"

namespace impostor::sdk {
namespace {

// One stream, from the file's first byte.
absl::Status UploadOnce(Transport& transport, const std::filesystem::path& path, const v1::Digest& digest,
                        const CancelSource* cancel) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::InternalError(absl::StrCat("cannot open ", path.string(), ": ", std::strerror(errno)));
  Transport::ChunkSource next = [&](std::string* data) -> absl::StatusOr<bool> {
    data->resize(kUploadChunkBytes);
    in.read(data->data(), static_cast<std::streamsize>(data->size()));
    if (in.bad()) return absl::InternalError(absl::StrCat("read error on ", path.string()));
    data->resize(static_cast<size_t>(in.gcount()));
    return !data->empty();
  };
  absl::StatusOr<v1::UploadBlobResponse> response = transport.UploadBlob(digest, next, cancel);
  if (!response.ok()) return response.status();
  if (response->already_present()) SdkLog().debug("{} was already in the store", path.string());
  return absl::OkStatus();
}

}  // namespace

absl::Status UploadBlobFile(Transport& transport, const std::filesystem::path& path, const v1::Digest& digest,
                            const CancelSource* cancel) {
  RetryPolicy retry = transport.NewRetryPolicy(cancel);
  while (true) {
    absl::Status status = UploadOnce(transport, path, digest, cancel);
    if (status.ok()) return status;
    if (cancel != nullptr && cancel->cancelled()) return cancel->error();
    if (!retry.ShouldRetry(status)) return retry.cancelled() ? cancel->error() : status;
    SdkLog().debug("upload of {} failed ({} in a row): {}; starting it over", path.string(), retry.failures(),
                   status.ToString());
  }
}

}  // namespace impostor::sdk
