// Downloads one blob into a partial file that survives failures and
// restarts, so that a transfer cut off midway resumes from the bytes already
// on disk (ReadBlob offset) instead of from zero, and hard-links the
// finished blob into an install's staging directory.
//
// Every use of a partial file is under its exclusive flock: writing it,
// checking it, linking it into a staging directory, and deleting it. A
// download therefore never depends on the partial's name after it released
// the lock (its staging directory holds a link to the bytes), and whoever
// deletes a partial (an install cleaning up, garbage collection) takes the
// lock without waiting and checks that the name still holds the file it
// locked, so it never pulls a partial from under a download. A partial held
// by a download that makes no progress (a stopped process) is waited for a
// few seconds at most: the blob is then fetched into the staging directory
// instead. Runs on the caller's thread.
#ifndef IMPOSTOR_CLIENT_CACHE_PARTIAL_DOWNLOAD_H_
#define IMPOSTOR_CLIENT_CACHE_PARTIAL_DOWNLOAD_H_

#include <sys/types.h>

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "client/base/unique_fd.h"
#include "client/transport/transport.h"
#include "common/util/sha256.h"
#include "impostor/v1/types.pb.h"

namespace impostor::sdk {

// How long a partial file locked by another download may go without
// growing before a download waiting for it stops waiting and fetches the
// blob into a file of its own: the holder is stopped (SIGSTOP, a debugger)
// or stuck. A holder that is moving bytes is waited for however long it
// takes.
inline constexpr double kPartialStallSeconds = 5;

// Observers for tests; empty members are skipped. Called on the
// downloading thread.
struct DownloadHooks {
  // A ReadBlob sequence for `sha256` is about to start at `offset` (the bytes
  // a partial file already had), under the partial's lock.
  std::function<void(const std::string& sha256, int64_t offset)> on_blob_start;
  // `received` bytes of `sha256` are now on disk.
  std::function<void(const std::string& sha256, int64_t received)> on_blob_bytes;
  // Another download (a thread or process) holds the partial file of
  // `sha256`: called once, before this one starts waiting for it.
  std::function<void(const std::string& sha256)> on_partial_wait;
  // The result of `key` has just been renamed into entries/ by this
  // download (already pinned; before its partial files are cleaned up).
  std::function<void(const std::string& key)> on_installed;
  // Replaces kPartialStallSeconds when > 0. Tests only.
  double partial_stall_seconds = 0;
};

// Which file a partial name held when a download used it.
struct FileIdentity {
  dev_t dev = 0;
  ino_t ino = 0;
};

struct BlobOutcome {
  int64_t bytes_downloaded = 0;  // fetched over the network by this call
  // Bytes of an unfinished partial file (an interrupted download's) that
  // this call completed instead of fetching them again. A partial that was
  // whole already (another download finished it) counts as neither.
  int64_t bytes_resumed = 0;
  // The links were made from the shared partial file `identity` (which the
  // install removes once done); false when the partial was held up and the
  // blob fetched into the staging directory instead.
  bool shared = true;
  FileIdentity identity;
  // The blob's file (the shared partial, or links[0] when not shared), left
  // open and unlocked: the install syncs it and removes the partial's name
  // through it, instead of opening the file by name twice more (a fleet of
  // small fetches is made of such calls).
  UniqueFd file;
};

// Where a blob's bytes come from: feeds bytes [offset, size) of `digest`
// to `sink` and `hash` (which has seen bytes [0, offset)) and checks the
// whole blob's SHA-256 at the end (DATA_LOSS, the sink having seen bad
// bytes). The farm's is ResumeBlobDownload (FarmBlobReader); a release
// mirror's is ReadVerified (transfer/http_blob_read.h).
using BlobReader = std::function<absl::Status(const v1::Digest& digest, int64_t offset, Sha256& hash,
                                              const std::function<absl::Status(std::string_view)>& sink,
                                              const CancelSource* cancel)>;
// ResumeBlobDownload through `transport` (which must outlive the reader).
BlobReader FarmBlobReader(Transport& transport);

// Makes each path of `links` (new names inside a staging directory the
// caller owns; at least one) a hard link to the verified blob
// `digest`, fetched through its partial file `partial`: bytes already there
// are hashed and kept, only the rest is requested. The blob's writeback is
// started, not waited for: the install makes all of a result's files
// durable together (SyncStagedFiles), one journal commit per result rather
// than one per file. A partial file whose
// bytes turn out wrong is truncated and the blob fetched once more from
// zero. On failure the bytes received so far stay in `partial` for the next
// try. `cancel` (may be null) is polled while waiting for the partial and
// between chunks: CANCELLED once it is true. Errors: ABORTED when `partial`
// was deleted while this call waited for it (the install that used it may
// be complete: the caller looks, then calls again), those of
// `reader`, INTERNAL or RESOURCE_EXHAUSTED for local I/O.
absl::StatusOr<BlobOutcome> FetchBlob(const BlobReader& reader, const v1::Digest& digest,
                                      const std::filesystem::path& partial,
                                      const std::vector<std::filesystem::path>& links, const DownloadHooks& hooks,
                                      const CancelSource* cancel);

// Deletes the partial file `path` if no one holds its lock, it is still
// the file `identity` (when given), and it was last modified at least
// `min_age_seconds` ago. Returns its size when deleted, -1 otherwise.
int64_t RemovePartialIfUnused(const std::filesystem::path& path, const FileIdentity* identity,
                              double min_age_seconds = 0);

// RemovePartialIfUnused for the partial file a download kept open as
// `file` (BlobOutcome::file; `identity` its FileIdentity): locked through
// it rather than opened again, deleted when its name still holds it, and
// closed. True when deleted.
bool RemoveOpenPartialIfUnused(const std::filesystem::path& path, UniqueFd file, const FileIdentity& identity);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_CACHE_PARTIAL_DOWNLOAD_H_
