#include "client/base/small_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>

#include "absl/strings/str_cat.h"
#include "client/base/local_io_error.h"

namespace impostor::sdk {

absl::StatusOr<std::string> ReadSmallFile(const std::filesystem::path& path, int64_t max_bytes) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    const int err = errno;
    if (err == ENOENT || err == ENOTDIR) return absl::NotFoundError(absl::StrCat(path.string(), ": absent"));
    return LocalIoError("cannot open", path, err);
  }
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st;
  if (::fstat(fd, &st) != 0) return LocalIoError("cannot stat", path, errno);
  if (!S_ISREG(st.st_mode)) return LocalIoError("cannot read", path, EISDIR);
  if (st.st_size > max_bytes) {
    return absl::OutOfRangeError(
        absl::StrCat(path.string(), ": ", st.st_size, " bytes is over the limit of ", max_bytes, " bytes"));
  }
  // One byte more than fstat said, up to one past the limit: a file that
  // grew meanwhile is read on to its end rather than cut short, and one
  // that grew past the limit shows as such.
  const size_t cap = static_cast<size_t>(max_bytes) + 1;
  std::string text(static_cast<size_t>(st.st_size) + 1, '\0');
  size_t have = 0;
  while (true) {
    if (have == text.size()) {
      if (text.size() >= cap) break;
      text.resize(std::min(text.size() * 2, cap));
    }
    const ssize_t n = ::read(fd, text.data() + have, text.size() - have);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return LocalIoError("cannot read", path, errno);
    if (n == 0) break;
    have += static_cast<size_t>(n);
  }
  if (have >= cap) {
    return absl::OutOfRangeError(
        absl::StrCat(path.string(), ": grew past the limit of ", max_bytes, " bytes while read"));
  }
  text.resize(have);
  return text;
}

}  // namespace impostor::sdk
