#include "server/http/release_files.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <utility>
#include <vector>

#include <spdlog/spdlog.h>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "common/util/log_escape.h"
#include "common/util/sha256.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

// Bytes read at a time for a check.
constexpr size_t kCheckChunkBytes = size_t{256} << 10;
// The channel name rule of release_format.md.
constexpr size_t kMaxChannelNameLength = 64;

bool IsLowerHex(char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); }

bool IsDigestHex(std::string_view s) {
  if (s.size() != 64) return false;
  for (char c : s) {
    if (!IsLowerHex(c)) return false;
  }
  return true;
}

bool IsChannelName(std::string_view s) {
  if (s.empty() || s.size() > kMaxChannelNameLength) return false;
  if (!absl::ascii_isalnum(static_cast<unsigned char>(s.front()))) return false;
  for (char c : s) {
    if (!absl::ascii_isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '_' && c != '-') return false;
  }
  return true;
}

// `text` cut at every '/' (empty parts kept).
std::vector<std::string_view> SplitPath(std::string_view text) {
  std::vector<std::string_view> parts;
  while (true) {
    const size_t slash = text.find('/');
    parts.push_back(text.substr(0, slash));
    if (slash == std::string_view::npos) return parts;
    text.remove_prefix(slash + 1);
  }
}

ReleaseFileIdentity IdentityOf(const struct stat& st) {
  return {.device = static_cast<uint64_t>(st.st_dev),
          .inode = static_cast<uint64_t>(st.st_ino),
          .size_bytes = static_cast<int64_t>(st.st_size),
          .mtime_ns = static_cast<int64_t>(st.st_mtim.tv_sec) * 1'000'000'000 + st.st_mtim.tv_nsec};
}

// A link (ELOOP from O_NOFOLLOW, ENOTDIR from O_DIRECTORY on a link to a
// file or on a file) or an absent entry: nothing to serve there.
bool MeansNotThere(int err) { return err == ENOENT || err == ENOTDIR || err == ELOOP; }

class ScopedFd {
 public:
  explicit ScopedFd(int fd) : fd_(fd) {}
  ~ScopedFd() {
    if (fd_ >= 0) ::close(fd_);
  }
  ScopedFd(const ScopedFd&) = delete;
  ScopedFd& operator=(const ScopedFd&) = delete;
  int get() const { return fd_; }
  int release() { return std::exchange(fd_, -1); }
  void reset(int fd) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = fd;
  }

 private:
  int fd_;
};

}  // namespace

std::string_view ReleaseFileKindName(ReleaseFileKind kind) {
  switch (kind) {
    case ReleaseFileKind::kBlob: return "blob";
    case ReleaseFileKind::kCatalog: return "catalog";
    case ReleaseFileKind::kChannel: return "channel";
  }
  return "unknown";
}

std::optional<ReleasePath> ParseReleasePath(std::string_view path) {
  const std::vector<std::string_view> parts = SplitPath(path);
  if (parts.size() == 5 && parts[0] == "v1" && (parts[1] == "blobs" || parts[1] == "catalogs") &&
      parts[2] == "sha256" && IsDigestHex(parts[4]) && parts[3] == parts[4].substr(0, 2)) {
    return ReleasePath{.kind = parts[1] == "blobs" ? ReleaseFileKind::kBlob : ReleaseFileKind::kCatalog,
                       .name = std::string(parts[4]),
                       .relative = std::string(path)};
  }
  if (parts.size() == 3 && parts[0] == "v1" && parts[1] == "channels" && parts[2].ends_with(".json")) {
    const std::string_view channel = parts[2].substr(0, parts[2].size() - 5);
    if (!IsChannelName(channel)) return std::nullopt;
    return ReleasePath{.kind = ReleaseFileKind::kChannel, .name = std::string(channel), .relative = std::string(path)};
  }
  return std::nullopt;
}

OpenReleaseFile::~OpenReleaseFile() {
  if (fd_ >= 0) ::close(fd_);
}

OpenReleaseFile::OpenReleaseFile(OpenReleaseFile&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)), identity_(other.identity_) {}

OpenReleaseFile& OpenReleaseFile::operator=(OpenReleaseFile&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = std::exchange(other.fd_, -1);
    identity_ = other.identity_;
  }
  return *this;
}

absl::Status OpenReleaseFile::ReadAt(int64_t offset, size_t length, std::string& out) const {
  out.resize(length);
  size_t got = 0;
  while (got < length) {
    const ssize_t n = ::pread(fd_, out.data() + got, length - got, static_cast<off_t>(offset + got));
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      out.clear();
      return absl::InternalError(absl::StrCat("read at byte ", offset + static_cast<int64_t>(got), ": ",
                                              std::strerror(err)));
    }
    if (n == 0) break;
    got += static_cast<size_t>(n);
  }
  out.resize(got);
  return absl::OkStatus();
}

ReleaseFileIdentity OpenReleaseFile::CurrentIdentity() const {
  struct stat st {};
  if (::fstat(fd_, &st) != 0) return {};
  return IdentityOf(st);
}

absl::StatusOr<std::string> OpenReleaseFile::ReadAll(int64_t max_bytes) const {
  if (identity_.size_bytes > max_bytes) {
    return absl::FailedPreconditionError(
        absl::StrCat("is ", identity_.size_bytes, " bytes; the limit is ", max_bytes));
  }
  std::string all;
  std::string chunk;
  // One byte past the limit is asked for: a file grown since it was opened
  // is refused rather than cut.
  while (true) {
    const size_t want = static_cast<size_t>(max_bytes + 1 - static_cast<int64_t>(all.size()));
    if (auto s = ReadAt(static_cast<int64_t>(all.size()), std::min(want, kCheckChunkBytes), chunk); !s.ok()) return s;
    if (chunk.empty()) break;
    all += chunk;
    if (static_cast<int64_t>(all.size()) > max_bytes) {
      return absl::FailedPreconditionError(absl::StrCat("is over the limit of ", max_bytes, " bytes"));
    }
  }
  return all;
}

absl::StatusOr<std::unique_ptr<ReleaseTree>> ReleaseTree::Open(const fs::path& root, Options options) {
  if (options.max_remembered < 1) return absl::InvalidArgumentError("max_remembered must be >= 1");
  std::error_code ec;
  const fs::file_status status = fs::status(root, ec);
  if (!fs::exists(status)) {
    return absl::InvalidArgumentError(
        absl::StrCat(root.string(), ": no such directory (a release tree: the directory that holds v1/)"));
  }
  if (!fs::is_directory(status)) {
    return absl::InvalidArgumentError(
        absl::StrCat(root.string(), ": not a directory (a release tree: the directory that holds v1/)"));
  }
  if (!fs::is_directory(root / "v1", ec)) {
    return absl::InvalidArgumentError(absl::StrCat(
        root.string(), " has no v1/ directory: not a release tree (`impostor publish` writes v1/blobs, "
                       "v1/catalogs and v1/channels into it)"));
  }
  fs::path absolute = fs::absolute(root, ec);
  if (ec) absolute = root;
  return std::unique_ptr<ReleaseTree>(new ReleaseTree(std::move(absolute), std::move(options)));
}

absl::StatusOr<OpenReleaseFile> ReleaseTree::OpenFile(const ReleasePath& path) const {
  auto failed = [&](int err, std::string_view what) -> absl::Status {
    if (MeansNotThere(err)) return absl::NotFoundError(absl::StrCat("no release file ", path.relative));
    return absl::InternalError(
        absl::StrCat("release file ", path.relative, ": ", std::string(what), ": ", std::strerror(err)));
  };
  // The root as configured (a link there is the admin's choice), then each
  // folder below it, then the file: never through a link.
  ScopedFd dir(::open(root_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (dir.get() < 0) {
    const int err = errno;
    return absl::InternalError(
        absl::StrCat("release tree ", root_.string(), ": cannot open its root: ", std::strerror(err)));
  }
  const std::vector<std::string_view> parts = SplitPath(path.relative);
  for (size_t i = 0; i + 1 < parts.size(); ++i) {
    const std::string name(parts[i]);
    const int next = ::openat(dir.get(), name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (next < 0) return failed(errno, "opening a folder on its way");
    dir.reset(next);
  }
  // O_NONBLOCK: a FIFO placed there must not hang the open (it is then
  // refused as not a regular file); it changes nothing for a regular file.
  const std::string file_name(parts.back());
  ScopedFd fd(::openat(dir.get(), file_name.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC));
  if (fd.get() < 0) return failed(errno, "open");
  struct stat st {};
  if (::fstat(fd.get(), &st) != 0) return failed(errno, "fstat");
  if (!S_ISREG(st.st_mode)) return absl::NotFoundError(absl::StrCat("no release file ", path.relative));
  return OpenReleaseFile(fd.release(), IdentityOf(st));
}

ReleaseTree::Outcome ReleaseTree::Check(const ReleasePath& path, const OpenReleaseFile& file) {
  Outcome outcome{.identity = file.identity(), .status = absl::OkStatus(), .actual_hex = ""};
  Sha256 hash;
  std::string chunk;
  int64_t offset = 0;
  while (true) {
    if (auto s = file.ReadAt(offset, kCheckChunkBytes, chunk); !s.ok()) {
      outcome.status = absl::InternalError(absl::StrCat("release file ", path.relative, ": ", s.message()));
      return outcome;
    }
    if (chunk.empty()) break;
    hash.Update(chunk);
    offset += static_cast<int64_t>(chunk.size());
  }
  // Written to while it was read: what was hashed may be neither version.
  if (offset != file.size_bytes() || file.CurrentIdentity() != file.identity()) {
    outcome.status = absl::UnavailableError(
        absl::StrCat("release file ", path.relative, " changed while it was checked; ask again"));
    return outcome;
  }
  outcome.actual_hex = hash.FinishHex();
  outcome.status = outcome.actual_hex == path.name ? absl::OkStatus() : absl::DataLossError("corrupt");
  return outcome;
}

absl::Status ReleaseTree::StatusOf(const ReleasePath& path, const Outcome& outcome) const {
  if (!absl::IsDataLoss(outcome.status)) return outcome.status;
  return absl::DataLossError(absl::StrCat("release file ", path.relative, " is corrupt: its name says sha256 ",
                                          path.name, ", its bytes hash to ", outcome.actual_hex,
                                          "; it is not served (publish it again, or remove it)"));
}

void ReleaseTree::Remember(const std::string& relative, const Outcome& outcome) {
  if (auto it = remembered_.find(relative); it != remembered_.end()) {
    it->second.outcome = outcome;
    lru_.splice(lru_.begin(), lru_, it->second.lru);
    return;
  }
  while (remembered_.size() >= options_.max_remembered) {
    remembered_.erase(lru_.back());
    lru_.pop_back();
  }
  lru_.push_front(relative);
  remembered_.emplace(relative, Remembered{.outcome = outcome, .lru = lru_.begin()});
}

absl::Status ReleaseTree::Verify(const ReleasePath& path, const OpenReleaseFile& file) {
  // A waiter that finds another version of the file was checked checks its
  // own next; a file rewritten again and again gives up after a few rounds.
  constexpr int kRounds = 4;
  for (int round = 0; round < kRounds; ++round) {
    std::shared_future<Outcome> pending;
    std::optional<std::promise<Outcome>> mine;  // set when this thread leads
    {
      absl::MutexLock lock(&mu_);
      if (auto it = remembered_.find(path.relative);
          it != remembered_.end() && it->second.outcome.identity == file.identity()) {
        lru_.splice(lru_.begin(), lru_, it->second.lru);
        return StatusOf(path, it->second.outcome);
      }
      if (auto it = in_flight_.find(path.relative); it != in_flight_.end()) {
        pending = it->second;
      } else {
        mine.emplace();
        in_flight_.emplace(path.relative, mine->get_future().share());
      }
    }
    if (pending.valid()) {
      if (options_.on_verify) options_.on_verify(false, path.relative);
      const Outcome& outcome = pending.get();
      if (outcome.identity == file.identity()) return StatusOf(path, outcome);
      continue;
    }
    if (options_.on_verify) options_.on_verify(true, path.relative);
    const Outcome outcome = Check(path, file);
    {
      absl::MutexLock lock(&mu_);
      ++verification_reads_;
      if (outcome.status.ok() || absl::IsDataLoss(outcome.status)) Remember(path.relative, outcome);
      in_flight_.erase(path.relative);
    }
    mine->set_value(outcome);
    if (absl::IsDataLoss(outcome.status)) {
      spdlog::warn("event=release_blob_corrupt kind={} path=\"{}\" root=\"{}\" expected_sha256={} actual_sha256={} "
                   "size_bytes={} note=\"not served until it is published again or removed\"",
                   ReleaseFileKindName(path.kind), path.relative, EscapeUntrusted(root_.string(), 300), path.name,
                   outcome.actual_hex, outcome.identity.size_bytes);
    }
    return StatusOf(path, outcome);
  }
  return absl::UnavailableError(
      absl::StrCat("release file ", path.relative, " kept changing while it was checked; ask again"));
}

int64_t ReleaseTree::verification_reads() const {
  absl::MutexLock lock(&mu_);
  return verification_reads_;
}

}  // namespace impostor
