// One input blob being written into a job's scratch folder as its bytes
// arrive. Plain write(2) rather than a stream, so that a full disk is known
// as ENOSPC (scratch_shortage.h) and not as a stream that silently stopped.
//
// Owns its file descriptor; one thread at a time.
#ifndef IMPOSTOR_WORKER_SCRATCH_FILE_H_
#define IMPOSTOR_WORKER_SCRATCH_FILE_H_

#include <cstdint>
#include <filesystem>
#include <string_view>

#include "absl/status/status.h"

namespace impostor {

// Creates the folders above input file `file`. INVALID_ARGUMENT naming the
// file when a path another input holds as a file is in the way (issue 23:
// the request decides these names); a full disk as ScratchWriteError.
absl::Status MakeInputFolder(const std::filesystem::path& file);

class ScratchFile {
 public:
  ScratchFile() = default;
  ~ScratchFile();
  ScratchFile(const ScratchFile&) = delete;
  ScratchFile& operator=(const ScratchFile&) = delete;

  // Creates `path` (and its folders) empty; never follows a symlink there.
  // Errors: MakeInputFolder's; ScratchWriteError("create", ...).
  absl::Status Create(const std::filesystem::path& path);
  // Appends `bytes`. Errors: ScratchWriteError("write", ...), marked as a
  // full scratch on ENOSPC/EDQUOT; FAILED_PRECONDITION when not created.
  absl::Status Append(std::string_view bytes);
  // Closes the file; the errors of Append.
  absl::Status Close();

  int64_t bytes_written() const { return bytes_written_; }

 private:
  int fd_ = -1;
  std::filesystem::path path_;
  int64_t bytes_written_ = 0;
};

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_SCRATCH_FILE_H_
