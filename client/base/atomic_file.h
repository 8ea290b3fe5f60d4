// Writes a file so that it appears complete or not at all: bytes go to a
// temporary file in the destination's directory (same filesystem, so the
// final rename is atomic), which is synced and renamed over the destination
// by Commit. Dropping the writer without Commit removes the temporary file.
//
// Not thread-safe; one owner writes one file.
#ifndef IMPOSTOR_CLIENT_BASE_ATOMIC_FILE_H_
#define IMPOSTOR_CLIENT_BASE_ATOMIC_FILE_H_

#include <filesystem>
#include <memory>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace impostor::sdk {

class AtomicFileWriter {
 public:
  // Creates the temporary file next to `destination`. INTERNAL naming the
  // directory when it cannot.
  static absl::StatusOr<std::unique_ptr<AtomicFileWriter>> Create(const std::filesystem::path& destination);
  ~AtomicFileWriter();
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;

  absl::Status Append(std::string_view data);
  // Starts writing the bytes so far to disk without waiting, so that a later
  // Sync finds them written: several files synced together then share one
  // journal commit (CommitAll).
  void StartWriteback();
  // Waits until the bytes are on disk. Commit does it when not done.
  absl::Status Sync();
  // Sync, then rename onto the destination. The writer is spent afterwards.
  absl::Status Commit();
  // Removes the temporary file now.
  void Abort();

  const std::filesystem::path& temp_path() const { return temp_path_; }
  // The temporary file's descriptor (-1 once committed or aborted): for an
  // early sync (early_sync.h), which keeps its own duplicate.
  int fd() const { return fd_; }

 private:
  AtomicFileWriter(std::filesystem::path destination, std::filesystem::path temp_path, int fd);

  std::filesystem::path destination_;
  std::filesystem::path temp_path_;
  int fd_ = -1;
  bool synced_ = false;
  bool done_ = false;
};

// Syncs every writer, then commits them in order: the files appear in that
// order, each complete, and their syncs wait once for the disk rather than
// once per file. Stops at the first failure (the writers not committed
// remove their temporary files when dropped).
absl::Status CommitAll(const std::vector<std::unique_ptr<AtomicFileWriter>>& writers);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_BASE_ATOMIC_FILE_H_
