#include "client/cache/entry_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "client/cache/cache_layout.h"

namespace impostor::sdk {
namespace {

// Opens dir/.entry and takes `operation`; -1 when the file is gone or the
// lock is not granted. The check after locking catches an entry moved away
// (evicted) between open and flock.
int OpenLocked(const std::filesystem::path& dir, int operation, int* error) {
  const std::filesystem::path path = dir / kEntryRecordName;
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    *error = errno;
    return -1;
  }
  int rc;
  do {
    rc = ::flock(fd, operation);
  } while (rc != 0 && errno == EINTR);
  struct stat locked, current;
  if (rc != 0 || ::fstat(fd, &locked) != 0 || ::stat(path.c_str(), &current) != 0 ||
      locked.st_ino != current.st_ino || locked.st_dev != current.st_dev) {
    *error = rc != 0 ? errno : ENOENT;
    ::close(fd);
    return -1;
  }
  return fd;
}

}  // namespace

absl::StatusOr<std::unique_ptr<EntryLock>> EntryLock::Shared(const std::filesystem::path& dir) {
  int error = 0;
  const int fd = OpenLocked(dir, LOCK_SH, &error);
  if (fd < 0) {
    return absl::NotFoundError(absl::StrCat("cannot lock ", dir.string(), ": ", std::strerror(error)));
  }
  return std::unique_ptr<EntryLock>(new EntryLock(fd));
}

std::unique_ptr<EntryLock> EntryLock::TryExclusive(const std::filesystem::path& dir) {
  int error = 0;
  const int fd = OpenLocked(dir, LOCK_EX | LOCK_NB, &error);
  if (fd < 0) return nullptr;
  return std::unique_ptr<EntryLock>(new EntryLock(fd));
}

EntryLock::~EntryLock() { ::close(fd_); }

}  // namespace impostor::sdk
