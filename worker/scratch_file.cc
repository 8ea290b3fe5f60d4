#include "worker/scratch_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <system_error>

#include "absl/strings/str_cat.h"
#include "common/util/disk_space.h"
#include "worker/scratch_shortage.h"

namespace impostor {

namespace fs = std::filesystem;

absl::Status MakeInputFolder(const fs::path& file) {
  // The error_code overload: a path another input holds as a file used to
  // throw here and terminate the worker (issue 23).
  std::error_code ec;
  fs::create_directories(file.parent_path(), ec);
  if (!ec) return absl::OkStatus();
  if (IsDiskFull(ec.value())) return ScratchWriteError("create the folder", file.parent_path(), ec.value());
  return absl::InvalidArgumentError(
      absl::StrCat("cannot create the folder for input ", file.filename().string(), ": ", ec.message()));
}

ScratchFile::~ScratchFile() {
  if (fd_ >= 0) ::close(fd_);
}

absl::Status ScratchFile::Create(const fs::path& path) {
  if (auto s = MakeInputFolder(path); !s.ok()) return s;
  path_ = path;
  bytes_written_ = 0;
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd_ < 0) return ScratchWriteError("create", path, errno);
  return absl::OkStatus();
}

absl::Status ScratchFile::Append(std::string_view bytes) {
  if (fd_ < 0) return absl::FailedPreconditionError(absl::StrCat("write ", path_.string(), ": not open"));
  while (!bytes.empty()) {
    const ssize_t n = ::write(fd_, bytes.data(), bytes.size());
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return ScratchWriteError("write", path_, errno);
    bytes.remove_prefix(static_cast<size_t>(n));
    bytes_written_ += n;
  }
  return absl::OkStatus();
}

absl::Status ScratchFile::Close() {
  if (fd_ < 0) return absl::OkStatus();
  const int fd = fd_;
  fd_ = -1;
  // Some filesystems (NFS) report a full disk only here.
  if (::close(fd) != 0 && errno != EINTR) return ScratchWriteError("write", path_, errno);
  return absl::OkStatus();
}

}  // namespace impostor
