#include "client/cache/partial_download.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <optional>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/blob_download.h"
#include "client/local_io_error.h"
#include "client/sdk_log.h"
#include "common/disk_space.h"
#include "common/sha256.h"
#include "impostor/client.h"

namespace impostor::sdk {
namespace {

// Closes the descriptor (and so drops its flock) on every path out.
class LockedFile {
 public:
  explicit LockedFile(int fd) : fd_(fd) {}
  ~LockedFile() {
    if (fd_ >= 0) ::close(fd_);
  }
  int fd() const { return fd_; }

 private:
  int fd_;
};

// Feeds the first `size` bytes of `fd` to `hash`.
absl::Status HashPrefix(int fd, int64_t size, Sha256& hash, const std::filesystem::path& path) {
  std::vector<char> buffer(1 << 20);
  int64_t done = 0;
  while (done < size) {
    const ssize_t n = ::pread(fd, buffer.data(), std::min<int64_t>(buffer.size(), size - done), done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return LocalIoError("cannot read", path, n < 0 ? errno : EIO);
    hash.Update(buffer.data(), static_cast<size_t>(n));
    done += n;
  }
  return absl::OkStatus();
}

absl::Status WriteAll(int fd, std::string_view data, const std::filesystem::path& path) {
  while (!data.empty()) {
    const ssize_t n = ::write(fd, data.data(), data.size());
    if (n < 0) {
      if (errno == EINTR) continue;
      return LocalIoError("cannot write", path, errno);
    }
    data.remove_prefix(static_cast<size_t>(n));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<PartialOutcome> DownloadToPartial(Transport& transport, const v1::Digest& digest,
                                                 const std::filesystem::path& path, const DownloadHooks& hooks,
                                                 const std::atomic<bool>* cancel) {
  // A holder that hit a full disk unlinks the file under the lock (see
  // below): a waiter then holds an orphan, and opens the path afresh.
  std::optional<LockedFile> file;
  for (int tries = 0;; ++tries) {
    file.emplace(::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644));
    if (file->fd() < 0) return LocalIoError("cannot open", path, errno);
    int rc;
    do {
      rc = ::flock(file->fd(), LOCK_EX);
    } while (rc != 0 && errno == EINTR);
    if (rc != 0) return LocalIoError("cannot lock", path, errno);
    struct stat st;
    if (::fstat(file->fd(), &st) != 0) return LocalIoError("cannot stat", path, errno);
    if (st.st_nlink > 0 || tries == 8) break;
  }

  PartialOutcome outcome;
  const int64_t size = digest.size_bytes();
  // Two passes at most: resume from what is there, and if those bytes were
  // bad, once more from zero.
  for (int pass = 0; pass < 2; ++pass) {
    struct stat st;
    if (::fstat(file->fd(), &st) != 0) return LocalIoError("cannot stat", path, errno);
    int64_t have = st.st_size;
    if (have > size) {
      if (::ftruncate(file->fd(), 0) != 0) return LocalIoError("cannot truncate", path, errno);
      have = 0;
    }
    Sha256 hash;
    if (absl::Status s = HashPrefix(file->fd(), have, hash, path); !s.ok()) return s;
    if (::lseek(file->fd(), have, SEEK_SET) < 0) return LocalIoError("cannot seek", path, errno);
    if (hooks.on_blob_start) hooks.on_blob_start(digest.hash(), have);
    int64_t received = have;
    absl::Status status;
    if (have == size) {
      // Complete already (an earlier run stopped after the last byte, or
      // another thread finished it while we waited for the lock).
      status = hash.FinishHex() == digest.hash()
                   ? absl::OkStatus()
                   : absl::DataLossError(absl::StrCat(path.string(), ": partial file does not match its digest"));
    } else {
      status = ResumeBlobDownload(transport, digest, have, hash, [&](std::string_view data) -> absl::Status {
        if (cancel != nullptr && cancel->load(std::memory_order_relaxed)) {
          return absl::CancelledError("the cache is shutting down");
        }
        if (absl::Status s = WriteAll(file->fd(), data, path); !s.ok()) return s;
        received += static_cast<int64_t>(data.size());
        outcome.bytes_downloaded += static_cast<int64_t>(data.size());
        if (hooks.on_blob_bytes) hooks.on_blob_bytes(digest.hash(), received);
        return absl::OkStatus();
      });
    }
    if (status.ok()) {
      if (::fdatasync(file->fd()) != 0) {
        const int err = errno;
        if (IsDiskFull(err)) {
          ::ftruncate(file->fd(), 0);
          ::unlink(path.c_str());
        }
        return LocalIoError("cannot sync", path, err);
      }
      outcome.bytes_resumed += have;
      return outcome;
    }
    // A digest mismatch of our own check (not an RPC's DATA_LOSS) with
    // resumed bytes: those bytes may be the bad ones. Start over once.
    const bool local_mismatch = status.code() == absl::StatusCode::kDataLoss && !GetRpcErrorInfo(status).has_value();
    if (local_mismatch && have > 0 && pass == 0) {
      SdkLog().warn("partial download {} did not verify ({}); fetching it again from zero", path.string(),
                    status.ToString());
      if (::ftruncate(file->fd(), 0) != 0) return LocalIoError("cannot truncate", path, errno);
      continue;
    }
    if (local_mismatch) {
      // Bad bytes from the server: keeping them would poison the next try.
      ::ftruncate(file->fd(), 0);
      return status;
    }
    if (IsLocalDiskFull(status)) {
      // The disk is full: the bytes kept for a resume would hold space that
      // everything else on it needs. Nothing is left behind.
      ::ftruncate(file->fd(), 0);
      ::unlink(path.c_str());
      return status;
    }
    // Interrupted: keep what arrived, durably, for the next try.
    ::fdatasync(file->fd());
    return status;
  }
  return absl::DataLossError(absl::StrCat(path.string(), ": download does not match its digest"));
}

}  // namespace impostor::sdk
