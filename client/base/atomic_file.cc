#include "client/base/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>
#include <system_error>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/base/local_io_error.h"

namespace impostor::sdk {

AtomicFileWriter::AtomicFileWriter(std::filesystem::path destination, std::filesystem::path temp_path, int fd)
    : destination_(std::move(destination)), temp_path_(std::move(temp_path)), fd_(fd) {}

absl::StatusOr<std::unique_ptr<AtomicFileWriter>> AtomicFileWriter::Create(const std::filesystem::path& destination) {
  const std::filesystem::path dir = destination.has_parent_path() ? destination.parent_path() : ".";
  // Hidden and unique, so concurrent fetches into one directory never share
  // a temporary file and a crash leaves only an obvious leftover.
  std::string pattern = (dir / ("." + destination.filename().string() + ".part-XXXXXX")).string();
  std::vector<char> buf(pattern.begin(), pattern.end());
  buf.push_back('\0');
  const int fd = mkstemp(buf.data());
  if (fd < 0) return LocalIoError("cannot create a file in", dir, errno);
  // mkstemp makes it 0600; a result is meant to be read like any file. (Not
  // 0666 & ~umask: reading the umask means setting it, which races with
  // other threads.)
  ::fchmod(fd, 0644);
  return std::unique_ptr<AtomicFileWriter>(new AtomicFileWriter(destination, buf.data(), fd));
}

AtomicFileWriter::~AtomicFileWriter() { Abort(); }

absl::Status AtomicFileWriter::Append(std::string_view data) {
  while (!data.empty()) {
    const ssize_t n = ::write(fd_, data.data(), data.size());
    if (n < 0) {
      if (errno == EINTR) continue;
      // The destination names what the user asked for; the temporary file
      // is gone once the caller aborts.
      return LocalIoError("cannot write", destination_, errno);
    }
    data.remove_prefix(static_cast<size_t>(n));
  }
  return absl::OkStatus();
}

void AtomicFileWriter::StartWriteback() {
  if (fd_ >= 0) (void)::sync_file_range(fd_, 0, 0, SYNC_FILE_RANGE_WRITE);
}

absl::Status AtomicFileWriter::Sync() {
  if (::fsync(fd_) != 0) return LocalIoError("cannot sync", destination_, errno);
  synced_ = true;
  return absl::OkStatus();
}

absl::Status CommitAll(const std::vector<std::unique_ptr<AtomicFileWriter>>& writers) {
  for (const auto& writer : writers) {
    if (absl::Status s = writer->Sync(); !s.ok()) return s;
  }
  for (const auto& writer : writers) {
    if (absl::Status s = writer->Commit(); !s.ok()) return s;
  }
  return absl::OkStatus();
}

absl::Status AtomicFileWriter::Commit() {
  if (!synced_) {
    if (absl::Status s = Sync(); !s.ok()) return s;
  }
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) return LocalIoError("cannot close", temp_path_, errno);
  if (::rename(temp_path_.c_str(), destination_.c_str()) != 0) {
    return LocalIoError(absl::StrCat("cannot rename ", temp_path_.string(), " to"), destination_, errno);
  }
  done_ = true;
  return absl::OkStatus();
}

void AtomicFileWriter::Abort() {
  if (fd_ >= 0) {
    ::close(fd_);
    fd_ = -1;
  }
  if (!done_) {
    std::error_code ec;
    std::filesystem::remove(temp_path_, ec);
    done_ = true;
  }
}

}  // namespace impostor::sdk
