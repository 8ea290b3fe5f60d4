// Downloads one blob through AssetService.ReadBlob, resuming from the bytes
// already received when the stream breaks, and verifying size and SHA-256 as
// the bytes arrive. Runs on the caller's thread.
#ifndef IMPOSTOR_CLIENT_TRANSFER_BLOB_DOWNLOAD_H_
#define IMPOSTOR_CLIENT_TRANSFER_BLOB_DOWNLOAD_H_

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "client/base/atomic_file.h"
#include "client/transport/retry.h"
#include "client/transport/transport.h"
#include "common/util/sha256.h"
#include "impostor/v1/types.pb.h"

namespace impostor::sdk {

// Feeds the blob's bytes, in order and each once, to `sink`. A broken stream
// (UNAVAILABLE, a stalled link, or an early end) is resumed at the byte after
// the last one received, as RetryPolicy decides: up to max_attempts tries in
// a row that bring no bytes, and through a server outage for up to
// max_outage_seconds. Bytes arriving start the count over, so a download
// that keeps moving is never given up, however slow the link; only a link
// that brings nothing for rpc_timeout_seconds, max_attempts times in a row,
// ends it (DEADLINE_EXCEEDED, "the link stalled"; Transport::ReadBlob).
// DATA_LOSS
// when the server sends more bytes than the digest's size, a wrong offset, or
// bytes whose SHA-256 differs (the sink has then seen bad bytes: the caller
// must discard them). A non-OK status from `sink` is returned as is.
//
// `cancel` (may be null; must outlive the call): CancelSource::Cancel() from
// any thread ends the download promptly wherever it is (a stream in
// flight, a backoff wait through an outage) with cancel->error()
// (CANCELLED); `sink` is not called after that.
absl::Status DownloadBlob(Transport& transport, const v1::Digest& digest,
                          const std::function<absl::Status(std::string_view)>& sink,
                          const CancelSource* cancel = nullptr);

// DownloadBlob from byte `offset` on, for a caller that already holds bytes
// [0, offset) and has fed them to `hash`: only the rest is requested and fed
// to `sink` and `hash`, and the SHA-256 of the whole blob is checked at the
// end. INVALID_ARGUMENT when offset is outside 0..size_bytes.
absl::Status ResumeBlobDownload(Transport& transport, const v1::Digest& digest, int64_t offset, Sha256& hash,
                                const std::function<absl::Status(std::string_view)>& sink,
                                const CancelSource* cancel = nullptr);

// DownloadBlob into `path` through an AtomicFileWriter: on any error the
// temporary file is removed and `path` is left untouched.
absl::Status DownloadBlobToFile(Transport& transport, const v1::Digest& digest, const std::filesystem::path& path);

// DownloadBlob into a temporary file beside `path`, not yet committed: its
// writeback started, for the caller to commit with others (CommitAll). On
// any error the temporary file is removed; a verification failure
// (DATA_LOSS) names `path`. `cancel` as for DownloadBlob.
absl::StatusOr<std::unique_ptr<AtomicFileWriter>> DownloadBlobToStagedFile(Transport& transport,
                                                                          const v1::Digest& digest,
                                                                          const std::filesystem::path& path,
                                                                          const CancelSource* cancel = nullptr);

// DownloadBlob into memory.
absl::StatusOr<std::string> DownloadBlobToString(Transport& transport, const v1::Digest& digest);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSFER_BLOB_DOWNLOAD_H_
