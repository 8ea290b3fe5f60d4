#include "client/transfer/blob_download.h"

#include <memory>

#include "absl/strings/str_cat.h"
#include "client/base/atomic_file.h"
#include "client/transport/retry.h"
#include "client/base/sdk_log.h"
#include "common/util/sha256.h"

namespace impostor::sdk {

absl::Status DownloadBlob(Transport& transport, const v1::Digest& digest,
                          const std::function<absl::Status(std::string_view)>& sink, const CancelSource* cancel) {
  Sha256 hash;
  return ResumeBlobDownload(transport, digest, 0, hash, sink, cancel);
}

absl::Status ResumeBlobDownload(Transport& transport, const v1::Digest& digest, int64_t offset, Sha256& hash,
                                const std::function<absl::Status(std::string_view)>& sink,
                                const CancelSource* cancel) {
  if (absl::Status s = ValidateDigest("digest", digest.hash(), digest.size_bytes()); !s.ok()) return s;
  const std::string name = absl::StrCat(digest.hash(), "/", digest.size_bytes());
  if (offset < 0 || offset > digest.size_bytes()) {
    return absl::InvalidArgumentError(
        absl::StrCat("ReadBlob ", name, ": resume offset ", offset, " is outside 0..", digest.size_bytes()));
  }
  int64_t received = offset;
  // Progress starts the count of failures over, so a slow but moving
  // download on a flaky link is never given up: each stream is only cut
  // when it stalls (Transport::ReadBlob has no deadline on the whole
  // stream), and the next resumes at the last byte received.
  RetryPolicy retry = transport.NewRetryPolicy(cancel);
  while (true) {
    const int64_t start = received;
    absl::Status status = transport.ReadBlob(digest, received, [&](const v1::ReadBlobResponse& msg) {
      if (msg.offset() != received) {
        return absl::DataLossError(absl::StrCat("ReadBlob ", name, ": chunk at offset ", msg.offset(),
                                                ", expected ", received));
      }
      if (static_cast<int64_t>(msg.data().size()) > digest.size_bytes() - received) {
        return absl::DataLossError(
            absl::StrCat("ReadBlob ", name, ": server sent more than the blob's ", digest.size_bytes(), " bytes"));
      }
      hash.Update(msg.data());
      received += static_cast<int64_t>(msg.data().size());
      return sink(msg.data());
    }, cancel);
    if (status.ok() && received == digest.size_bytes()) break;
    if (received > start) retry.MadeProgress();
    // A stream that ended OK but short is treated like a broken one (the
    // server answered, so max_attempts bounds the tries, not the outage).
    if (status.ok()) {
      const absl::Status short_stream = absl::DataLossError(absl::StrCat(
          "ReadBlob ", name, ": stream ended after ", received, " of ", digest.size_bytes(), " bytes"));
      if (!retry.ShouldRetry(absl::UnavailableError(short_stream.message()))) {
        return retry.cancelled() ? cancel->error() : short_stream;
      }
    } else if (!retry.ShouldRetry(status)) {
      return retry.cancelled() ? cancel->error() : status;
    }
    SdkLog().debug("download of {} interrupted at byte {} ({}); resuming", name, received, status.ToString());
  }
  const std::string actual = hash.FinishHex();
  if (actual != digest.hash()) {
    return absl::DataLossError(absl::StrCat("ReadBlob ", name, ": received bytes hash to ", actual));
  }
  return absl::OkStatus();
}

absl::Status DownloadBlobToFile(Transport& transport, const v1::Digest& digest, const std::filesystem::path& path) {
  absl::StatusOr<std::unique_ptr<AtomicFileWriter>> writer = DownloadBlobToStagedFile(transport, digest, path);
  if (!writer.ok()) return writer.status();
  return (*writer)->Commit();
}

absl::StatusOr<std::unique_ptr<AtomicFileWriter>> DownloadBlobToStagedFile(Transport& transport,
                                                                          const v1::Digest& digest,
                                                                          const std::filesystem::path& path,
                                                                          const CancelSource* cancel) {
  absl::StatusOr<std::unique_ptr<AtomicFileWriter>> writer = AtomicFileWriter::Create(path);
  if (!writer.ok()) return writer.status();
  absl::Status status =
      DownloadBlob(transport, digest, [&](std::string_view data) { return (*writer)->Append(data); }, cancel);
  if (!status.ok()) {
    (*writer)->Abort();
    // Name the file for local verification failures; an RPC's error already
    // names the RPC and server and keeps its details.
    if (status.code() == absl::StatusCode::kDataLoss && !GetRpcErrorInfo(status).has_value()) {
      return absl::DataLossError(absl::StrCat(path.string(), ": ", status.message()));
    }
    return status;
  }
  (*writer)->StartWriteback();
  return writer;
}

absl::StatusOr<std::string> DownloadBlobToString(Transport& transport, const v1::Digest& digest) {
  std::string out;
  absl::Status status = DownloadBlob(transport, digest, [&](std::string_view data) {
    out.append(data);
    return absl::OkStatus();
  });
  if (!status.ok()) return status;
  return out;
}

}  // namespace impostor::sdk
