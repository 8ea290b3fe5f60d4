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
  // fsync, then rename onto the destination. The writer is spent afterwards.
  absl::Status Commit();
  // Removes the temporary file now.
  void Abort();

  const std::filesystem::path& temp_path() const { return temp_path_; }

 private:
  AtomicFileWriter(std::filesystem::path destination, std::filesystem::path temp_path, int fd);

  std::filesystem::path destination_;
  std::filesystem::path temp_path_;
  int fd_ = -1;
  bool done_ = false;
};

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_BASE_ATOMIC_FILE_H_
