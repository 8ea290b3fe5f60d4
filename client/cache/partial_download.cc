#include "client/cache/partial_download.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <thread>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/transfer/blob_download.h"
#include "client/base/local_io_error.h"
#include "client/base/sdk_log.h"
#include "common/util/disk_space.h"
#include "common/util/sha256.h"
#include "impostor/client.h"

namespace impostor::sdk {
namespace {

namespace fs = std::filesystem;

absl::Status Cancelled() { return absl::CancelledError("the cache is shutting down"); }

bool IsCancelled(const CancelSource* cancel) { return cancel != nullptr && cancel->cancelled(); }

// Feeds the first `size` bytes of `fd` to `hash`.
absl::Status HashPrefix(int fd, int64_t size, Sha256& hash, const fs::path& path) {
  if (size <= 0) return absl::OkStatus();  // the usual case: a fresh partial, nothing to read
  // No larger than what there is to read: a 1 MiB buffer zeroed per blob
  // was 4 % of a fleet of small fetches.
  std::vector<char> buffer(static_cast<size_t>(std::min<int64_t>(size, 1 << 20)));
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

absl::Status WriteAll(int fd, std::string_view data, const fs::path& path) {
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

// True when `path` names the file open as `fd` (it was not deleted or
// replaced meanwhile); fills `identity` with the open file's, and
// `open_file` with its fstat (what the callers would otherwise ask again).
bool SameFile(int fd, const fs::path& path, FileIdentity* identity, struct stat* open_file) {
  struct stat named;
  if (::fstat(fd, open_file) != 0) return false;
  if (identity != nullptr) *identity = {open_file->st_dev, open_file->st_ino};
  return ::lstat(path.c_str(), &named) == 0 && named.st_dev == open_file->st_dev && named.st_ino == open_file->st_ino;
}

// flock(LOCK_EX | LOCK_NB): 0, or the errno.
int TryLockExclusive(int fd) {
  int rc;
  do {
    rc = ::flock(fd, LOCK_EX | LOCK_NB);
  } while (rc != 0 && errno == EINTR);
  return rc == 0 ? 0 : errno;
}

enum class Locked { kYes, kHolderStalled };

// Takes the exclusive lock of the partial file open as `fd`. While another
// download holds it, polls (never blocks: `cancel` is honoured, and a
// stopped holder does not hold us forever) for as long as the file keeps
// changing; kHolderStalled once it has not for the stall limit.
absl::StatusOr<Locked> LockPartial(int fd, const fs::path& path, const std::string& sha256, const DownloadHooks& hooks,
                                   const CancelSource* cancel) {
  int err = TryLockExclusive(fd);
  if (err == 0) return Locked::kYes;
  if (err != EWOULDBLOCK) return LocalIoError("cannot lock", path, err);
  if (hooks.on_partial_wait) hooks.on_partial_wait(sha256);
  const std::chrono::duration<double> stall_limit(hooks.partial_stall_seconds > 0 ? hooks.partial_stall_seconds
                                                                                 : kPartialStallSeconds);
  // Progress is the holder writing: the size or the modification time moves.
  auto mark = [fd] {
    struct stat st;
    if (::fstat(fd, &st) != 0) return std::pair<int64_t, int64_t>(-1, -1);
    return std::pair<int64_t, int64_t>(st.st_size,
                                       static_cast<int64_t>(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec);
  };
  std::pair<int64_t, int64_t> last_mark = mark();
  auto last_progress = std::chrono::steady_clock::now();
  std::chrono::milliseconds pause(1);
  while (true) {
    if (IsCancelled(cancel)) return Cancelled();
    // The pause ends at once when the cache closes.
    if (cancel != nullptr ? cancel->WaitFor(pause) : (std::this_thread::sleep_for(pause), false)) return Cancelled();
    pause = std::min(pause * 2, std::chrono::milliseconds(50));
    err = TryLockExclusive(fd);
    if (err == 0) return Locked::kYes;
    if (err != EWOULDBLOCK) return LocalIoError("cannot lock", path, err);
    const auto now = std::chrono::steady_clock::now();
    if (const std::pair<int64_t, int64_t> current = mark(); current != last_mark) {
      last_mark = current;
      last_progress = now;
    } else if (now - last_progress >= stall_limit) {
      return Locked::kHolderStalled;
    }
  }
}

// Fetches the blob from byte `have` on into `fd` (positioned there), hashing
// into `hash` (which has seen bytes [0, have)).
absl::Status Transfer(const BlobReader& reader, const v1::Digest& digest, int fd, const fs::path& path, int64_t have,
                      Sha256& hash, const DownloadHooks& hooks, const CancelSource* cancel,
                      int64_t* downloaded) {
  int64_t received = have;
  return reader(digest, have, hash, [&](std::string_view data) -> absl::Status {
    if (IsCancelled(cancel)) return Cancelled();
    if (absl::Status s = WriteAll(fd, data, path); !s.ok()) return s;
    received += static_cast<int64_t>(data.size());
    *downloaded += static_cast<int64_t>(data.size());
    if (hooks.on_blob_bytes) hooks.on_blob_bytes(digest.hash(), received);
    return absl::OkStatus();
  }, cancel);
}

// Starts writing the blob's bytes to disk without waiting: by the time the
// install syncs its files (SyncStagedFiles) most are written, and their
// syncs share one journal commit. A failure here shows again at that sync.
void StartWriteback(int fd) { (void)::sync_file_range(fd, 0, 0, SYNC_FILE_RANGE_WRITE); }

absl::Status LinkAll(const fs::path& from, const std::vector<fs::path>& links, size_t first) {
  for (size_t i = first; i < links.size(); ++i) {
    if (::link(from.c_str(), links[i].c_str()) != 0) {
      return LocalIoError(absl::StrCat("cannot link ", from.string(), " to"), links[i], errno);
    }
  }
  return absl::OkStatus();
}

// The blob fetched from zero straight into links[0] (in the caller's staging
// directory, which is removed with everything in it if the install fails),
// then linked under the other names. For a partial file held up by a
// download that makes no progress.
absl::StatusOr<BlobOutcome> FetchPrivately(const BlobReader& reader, const v1::Digest& digest,
                                           const std::vector<fs::path>& links, const DownloadHooks& hooks,
                                           const CancelSource* cancel) {
  const fs::path& target = links.front();
  UniqueFd file(::open(target.c_str(), O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0644));
  if (file.get() < 0) return LocalIoError("cannot create", target, errno);
  BlobOutcome outcome;
  outcome.shared = false;
  if (hooks.on_blob_start) hooks.on_blob_start(digest.hash(), 0);
  Sha256 hash;
  absl::Status status = Transfer(reader, digest, file.get(), target, 0, hash, hooks, cancel, &outcome.bytes_downloaded);
  if (status.ok()) StartWriteback(file.get());
  if (!status.ok()) {
    ::unlink(target.c_str());
    return status;
  }
  if (absl::Status s = LinkAll(target, links, 1); !s.ok()) return s;
  outcome.file = std::move(file);
  return outcome;
}

}  // namespace

BlobReader FarmBlobReader(Transport& transport) {
  return [&transport](const v1::Digest& digest, int64_t offset, Sha256& hash,
                      const std::function<absl::Status(std::string_view)>& sink, const CancelSource* cancel) {
    return ResumeBlobDownload(transport, digest, offset, hash, sink, cancel);
  };
}

absl::StatusOr<BlobOutcome> FetchBlob(const BlobReader& reader, const v1::Digest& digest, const fs::path& partial,
                                      const std::vector<fs::path>& links, const DownloadHooks& hooks,
                                      const CancelSource* cancel) {
  if (links.empty()) return absl::InternalError(absl::StrCat(partial.string(), ": nothing to link it to"));
  if (IsCancelled(cancel)) return Cancelled();
  UniqueFd file(::open(partial.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644));
  if (file.get() < 0) return LocalIoError("cannot open", partial, errno);
  absl::StatusOr<Locked> locked = LockPartial(file.get(), partial, digest.hash(), hooks, cancel);
  if (!locked.ok()) return locked.status();
  if (*locked == Locked::kHolderStalled) {
    SdkLog().warn("cache: {} is held by a download that has written nothing for {} s (a stopped process?); "
                  "fetching the blob on its own",
                  partial.string(), hooks.partial_stall_seconds > 0 ? hooks.partial_stall_seconds : kPartialStallSeconds);
    return FetchPrivately(reader, digest, links, hooks, cancel);
  }
  BlobOutcome outcome;
  // A holder that finished an install (or hit a full disk), or garbage
  // collection, may have deleted the name while we waited: the file we
  // locked is then no partial any more.
  struct stat st;
  if (!SameFile(file.get(), partial, &outcome.identity, &st)) {
    return absl::AbortedError(absl::StrCat(partial.string(), ": deleted while waiting for it"));
  }

  const int fd = file.get();
  const int64_t size = digest.size_bytes();
  // Two passes at most: resume from what is there, and if those bytes were
  // bad, once more from zero. The first pass sizes the file from SameFile's
  // fstat (taken under the lock); a fresh partial is read and written from
  // offset 0, where open left it (HashPrefix reads with pread).
  for (int pass = 0; pass < 2; ++pass) {
    if (pass > 0 && ::fstat(fd, &st) != 0) return LocalIoError("cannot stat", partial, errno);
    int64_t have = st.st_size;
    if (have > size) {
      if (::ftruncate(fd, 0) != 0) return LocalIoError("cannot truncate", partial, errno);
      have = 0;
    }
    Sha256 hash;
    if (absl::Status s = HashPrefix(fd, have, hash, partial); !s.ok()) return s;
    if (!(pass == 0 && have == 0) && ::lseek(fd, have, SEEK_SET) < 0) {
      return LocalIoError("cannot seek", partial, errno);
    }
    if (hooks.on_blob_start) hooks.on_blob_start(digest.hash(), have);
    absl::Status status;
    if (have == size) {
      // Whole already (another download finished it, or an earlier run
      // stopped after the last byte): nothing of it is this call's.
      status = hash.FinishHex() == digest.hash()
                   ? absl::OkStatus()
                   : absl::DataLossError(absl::StrCat(partial.string(), ": partial file does not match its digest"));
    } else {
      status = Transfer(reader, digest, fd, partial, have, hash, hooks, cancel, &outcome.bytes_downloaded);
    }
    if (status.ok()) {
      StartWriteback(fd);
      // Linked while locked: once we let go, the bytes are the staging
      // directory's as well, whatever becomes of the partial's name.
      if (absl::Status s = LinkAll(partial, links, 0); !s.ok()) return s;
      if (have < size) outcome.bytes_resumed += have;
      // Unlocked for other downloads of the blob, kept open for the
      // install (BlobOutcome::file).
      if (::flock(fd, LOCK_UN) != 0) return LocalIoError("cannot unlock", partial, errno);
      outcome.file = std::move(file);
      return outcome;
    }
    // A digest mismatch of our own check (not an RPC's DATA_LOSS) with
    // resumed bytes: those bytes may be the bad ones. Start over once.
    const bool local_mismatch = status.code() == absl::StatusCode::kDataLoss && !GetRpcErrorInfo(status).has_value();
    if (local_mismatch && have > 0 && pass == 0) {
      SdkLog().warn("partial download {} did not verify ({}); fetching it again from zero", partial.string(),
                    status.ToString());
      if (::ftruncate(fd, 0) != 0) return LocalIoError("cannot truncate", partial, errno);
      continue;
    }
    if (local_mismatch) {
      // Bad bytes from the server: keeping them would poison the next try.
      ::ftruncate(fd, 0);
      return status;
    }
    if (IsLocalDiskFull(status)) {
      // The disk is full: the bytes kept for a resume would hold space that
      // everything else on it needs. Nothing is left behind.
      ::ftruncate(fd, 0);
      ::unlink(partial.c_str());
      return status;
    }
    // Interrupted: keep what arrived, durably, for the next try.
    ::fdatasync(fd);
    return status;
  }
  return absl::DataLossError(absl::StrCat(partial.string(), ": download does not match its digest"));
}

int64_t RemovePartialIfUnused(const fs::path& path, const FileIdentity* identity, double min_age_seconds) {
  auto old_enough = [min_age_seconds](const struct stat& st) {
    if (min_age_seconds <= 0) return true;
    const double age = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count() -
                       (static_cast<double>(st.st_mtim.tv_sec) + st.st_mtim.tv_nsec * 1e-9);
    return age >= min_age_seconds;
  };
  struct stat st;
  // Young files are not even locked: that would make a download that wants
  // the lock right then wait a moment, or an install's cleanup skip them.
  // (An install's cleanup, min_age 0, goes straight to the lock: one look
  // fewer per blob.)
  if (min_age_seconds > 0 && (::lstat(path.c_str(), &st) != 0 || !old_enough(st))) return -1;
  UniqueFd file(::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW));
  if (file.get() < 0) return -1;
  if (TryLockExclusive(file.get()) != 0) return -1;  // a download is using it
  FileIdentity locked;
  // Deleted or replaced meanwhile; st is now the locked file's own.
  if (!SameFile(file.get(), path, &locked, &st)) return -1;
  if (identity != nullptr && (identity->dev != locked.dev || identity->ino != locked.ino)) return -1;
  if (!old_enough(st)) return -1;  // written since we looked
  if (::unlink(path.c_str()) != 0) return -1;
  return static_cast<int64_t>(st.st_size);
}

bool RemoveOpenPartialIfUnused(const fs::path& path, UniqueFd file, const FileIdentity& identity) {
  // The lock, if taken, goes when `file` closes on return.
  if (!file.valid() || TryLockExclusive(file.get()) != 0) return false;  // a download is using it
  struct stat named;
  return ::lstat(path.c_str(), &named) == 0 && named.st_dev == identity.dev && named.st_ino == identity.ino &&
         ::unlink(path.c_str()) == 0;
}

}  // namespace impostor::sdk
