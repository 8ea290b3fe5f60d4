// Downloads one blob into a partial file that survives failures and
// restarts, so that a transfer cut off midway resumes from the bytes already
// on disk (ReadBlob offset) instead of from zero. The file is locked
// (flock) while in use, so two threads or processes fetching the same blob
// take turns instead of interleaving bytes; the second then finds it
// complete. Runs on the caller's thread.
#ifndef IMPOSTOR_CLIENT_CACHE_PARTIAL_DOWNLOAD_H_
#define IMPOSTOR_CLIENT_CACHE_PARTIAL_DOWNLOAD_H_

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

#include "absl/status/status.h"
#include "client/transport.h"
#include "impostor/v1/types.pb.h"

namespace impostor::sdk {

// Observers for tests; empty members are skipped. Called on the
// downloading thread.
struct DownloadHooks {
  // A ReadBlob sequence for `sha256` is about to start at `offset` (the bytes
  // a partial file already had).
  std::function<void(const std::string& sha256, int64_t offset)> on_blob_start;
  // `received` bytes of `sha256` are now on disk.
  std::function<void(const std::string& sha256, int64_t received)> on_blob_bytes;
};

struct PartialOutcome {
  int64_t bytes_downloaded = 0;  // fetched over the network by this call
  int64_t bytes_resumed = 0;     // already in the partial file and kept
};

// Makes `path` hold exactly the blob `digest`, verified and synced. Bytes
// already in `path` are hashed and kept; only the rest is requested. A
// partial file whose bytes turn out wrong is truncated and the blob fetched
// once more from zero. On failure the bytes received so far stay in `path`
// for the next try. `cancel` (may be null) is polled between chunks:
// CANCELLED once it is true. Errors: those of ResumeBlobDownload, INTERNAL
// for local I/O.
absl::StatusOr<PartialOutcome> DownloadToPartial(Transport& transport, const v1::Digest& digest,
                                                 const std::filesystem::path& path, const DownloadHooks& hooks,
                                                 const std::atomic<bool>* cancel);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_CACHE_PARTIAL_DOWNLOAD_H_
