#include "server/blobs/blob_store.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cerrno>
#include <cstring>
#include <vector>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "common/error_reason.h"
#include "server/blobs/disk_full.h"

namespace impostor {
namespace fs = std::filesystem;
namespace {

// RESOURCE_EXHAUSTED with the free space, marked STORE_FULL: a full store
// is the farm's state, not the blob's, so a worker's result upload waits
// for space instead of failing its job for good (common/error_reason.h).
absl::Status StoreFullError(std::string_view what, const fs::path& path, std::string_view cause) {
  return WithErrorReason(DiskFullError(what, path, cause), error_reason::kStoreFull);
}

// INTERNAL naming the call and path; StoreFullError when the disk or quota
// is full.
absl::Status ErrnoError(std::string_view what, const fs::path& path) {
  const int error_number = errno;
  if (IsDiskFull(error_number)) return StoreFullError(what, path, std::strerror(error_number));
  return absl::InternalError(absl::StrCat(std::string(what), " ", path.string(), ": ", std::strerror(error_number)));
}

absl::Status SyncDirectory(const fs::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (fd < 0) return ErrnoError("open directory", dir);
  const int rc = ::fsync(fd);
  ::close(fd);
  if (rc != 0) return ErrnoError("fsync directory", dir);
  return absl::OkStatus();
}

std::string UniqueSuffix() {
  static std::atomic<uint64_t> counter{0};
  return absl::StrCat(::getpid(), "-", counter.fetch_add(1));
}

}  // namespace

// Writes one upload into its temporary file (a fresh one, or a claimed kept
// partial whose bytes are re-hashed first), registered with the store as a
// streaming upload until it is committed, kept or destroyed.
class BlobFileWriter final : public BlobStore::Writer {
 public:
  BlobFileWriter(BlobStore* store, BlobDigest digest, fs::path tmp_path, fs::path final_path, int fd,
                 int64_t written, std::shared_ptr<BlobStore::ActiveUpload> active)
      : store_(store),
        digest_(std::move(digest)),
        key_(BlobStore::PartialKey(digest_)),
        tmp_path_(std::move(tmp_path)),
        final_path_(std::move(final_path)),
        fd_(fd),
        written_(written),
        active_(std::move(active)) {}

  ~BlobFileWriter() override {
    if (fd_ >= 0) ::close(fd_);
    if (!committed_ && !kept_) {
      std::error_code ec;
      fs::remove(tmp_path_, ec);
    }
    store_->EndActive(key_, active_.get());
  }

  // Hashes the resumed prefix (the first written_ bytes of the file), so
  // that Commit verifies the whole blob as for a fresh upload. INTERNAL or
  // FAILED_PRECONDITION (the file is shorter than it was when kept).
  absl::Status HashPrefix() {
    std::vector<char> buf(size_t{1} << 20);
    int64_t pos = 0;
    while (pos < written_) {
      const size_t want = static_cast<size_t>(std::min<int64_t>(written_ - pos, static_cast<int64_t>(buf.size())));
      const ssize_t n = ::pread(fd_, buf.data(), want, pos);
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) return ErrnoError("read", tmp_path_);
      if (n == 0) {
        return absl::FailedPreconditionError(absl::StrCat("blob ", digest_.hash, ": the kept partial upload lost bytes (",
                                                          pos, " of ", written_, " left); start at 0"));
      }
      hash_.Update(buf.data(), static_cast<size_t>(n));
      pos += n;
    }
    return absl::OkStatus();
  }

  absl::Status Append(std::string_view data) override {
    if (written_ + static_cast<int64_t>(data.size()) > digest_.size_bytes) {
      return absl::InvalidArgumentError(absl::StrCat("blob ", digest_.hash, ": received more than the ",
                                                     digest_.size_bytes, " bytes its digest declares"));
    }
    hash_.Update(data);
    while (!data.empty()) {
      const ssize_t n = ::pwrite(fd_, data.data(), data.size(), written_);
      if (n < 0) {
        if (errno == EINTR) continue;
        return ErrnoError("write", tmp_path_);
      }
      data.remove_prefix(static_cast<size_t>(n));
      written_ += n;
      active_->written = written_;
    }
    return absl::OkStatus();
  }

  absl::StatusOr<bool> Commit() override {
    if (written_ != digest_.size_bytes) {
      return absl::InvalidArgumentError(absl::StrCat("blob ", digest_.hash, ": size mismatch: digest says ",
                                                     digest_.size_bytes, " bytes, received ", written_));
    }
    const std::string actual = hash_.FinishHex();
    if (actual != digest_.hash) {
      return absl::InvalidArgumentError(
          absl::StrCat("blob hash mismatch: digest says ", digest_.hash, ", content hashes to ", actual));
    }
    if (::fsync(fd_) != 0) return ErrnoError("fsync", tmp_path_);
    ::close(fd_);
    fd_ = -1;
    std::error_code ec;
    if (fs::exists(final_path_, ec)) return true;
    fs::create_directories(final_path_.parent_path(), ec);
    if (ec && IsDiskFull(ec.value())) return StoreFullError("create", final_path_.parent_path(), ec.message());
    if (::rename(tmp_path_.c_str(), final_path_.c_str()) != 0) return ErrnoError("rename into", final_path_);
    committed_ = true;
    store_->AddPublished(digest_.size_bytes);
    if (auto s = SyncDirectory(final_path_.parent_path()); !s.ok()) return s;
    return false;
  }

  int64_t written() const override { return written_; }

  void Keep() override {
    if (committed_ || kept_) return;
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
    kept_ = true;
    store_->KeepPartialAndEnd(key_, tmp_path_, written_, active_.get());
  }

  bool preempted() const override { return active_->preempted; }

 private:
  BlobStore* const store_;
  const BlobDigest digest_;
  const std::string key_;
  const fs::path tmp_path_;
  const fs::path final_path_;
  int fd_;
  Sha256 hash_;
  int64_t written_;
  bool committed_ = false;
  bool kept_ = false;
  const std::shared_ptr<BlobStore::ActiveUpload> active_;
};

BlobStore::BlobStore(fs::path root, int64_t max_blob_bytes, PartialUploadLimits partial_limits)
    : root_(std::move(root)),
      cas_dir_(root_ / "cas"),
      tmp_dir_(root_ / "tmp"),
      quarantine_dir_(root_ / "quarantine"),
      max_blob_bytes_(max_blob_bytes),
      partial_limits_(std::move(partial_limits)) {}

absl::StatusOr<std::unique_ptr<BlobStore>> BlobStore::Open(const fs::path& root, int64_t max_blob_bytes,
                                                           PartialUploadLimits partial_limits) {
  std::unique_ptr<BlobStore> store(new BlobStore(root, max_blob_bytes, std::move(partial_limits)));
  std::error_code ec;
  fs::create_directories(store->cas_dir_, ec);
  if (ec) return absl::InternalError(absl::StrCat("cannot create ", store->cas_dir_.string(), ": ", ec.message()));
  // Leftovers of uploads a crash interrupted: never visible, safe to drop.
  // Only old ones: servers sharing this directory (issue 15) may be
  // writing younger ones right now.
  const auto stale_before = fs::file_time_type::clock::now() - std::chrono::hours(1);
  for (const auto& entry : fs::directory_iterator(store->tmp_dir_, ec)) {
    std::error_code ignored;
    if (entry.last_write_time(ignored) < stale_before) fs::remove_all(entry.path(), ignored);
  }
  ec.clear();
  fs::create_directories(store->tmp_dir_, ec);
  if (ec) return absl::InternalError(absl::StrCat("cannot create ", store->tmp_dir_.string(), ": ", ec.message()));
  for (const StoredBlob& b : store->List()) store->total_bytes_ += b.size_bytes;
  return store;
}

std::vector<BlobStore::StoredBlob> BlobStore::List() const {
  std::vector<StoredBlob> out;
  std::error_code ec;
  for (const auto& entry : fs::recursive_directory_iterator(cas_dir_, ec)) {
    struct stat st {};
    if (!entry.is_regular_file(ec) || ::stat(entry.path().c_str(), &st) != 0) continue;
    const std::string name = entry.path().filename().string();
    if (!IsSha256Hex(name)) continue;
    out.push_back({name, st.st_size, int64_t{st.st_mtim.tv_sec} * 1'000'000'000 + st.st_mtim.tv_nsec});
  }
  return out;
}

int64_t BlobStore::Recount(const std::vector<StoredBlob>& scan) {
  int64_t total = 0;
  for (const StoredBlob& b : scan) total += b.size_bytes;
  total_bytes_ = total;
  return total;
}

absl::Status BlobStore::Remove(const std::string& hash) {
  if (!IsSha256Hex(hash)) return absl::InvalidArgumentError("hash: not a SHA-256 hex string");
  const fs::path path = cas_dir_ / hash.substr(0, 2) / hash;
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return absl::OkStatus();
  if (::unlink(path.c_str()) != 0 && errno != ENOENT) return ErrnoError("remove", path);
  total_bytes_ -= st.st_size;
  std::lock_guard lock(verified_mu_);
  verified_.erase(hash);
  return absl::OkStatus();
}

fs::path BlobStore::PathFor(const BlobDigest& digest) const {
  return cas_dir_ / digest.hash.substr(0, 2) / digest.hash;
}

absl::StatusOr<std::unique_ptr<BlobStore::Writer>> BlobStore::NewWriter(const BlobDigest& digest, int64_t offset,
                                                                     std::function<void()> cancel_stream) {
  if (auto s = ValidateDigest("digest", digest.hash, digest.size_bytes); !s.ok()) return s;
  if (digest.size_bytes > max_blob_bytes_) {
    return absl::InvalidArgumentError(absl::StrCat("digest.size_bytes: ", digest.size_bytes,
                                                   " is over the blob size limit of ", max_blob_bytes_));
  }
  if (offset < 0 || offset > digest.size_bytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("offset: ", offset, " is outside the blob's 0..", digest.size_bytes, " bytes"));
  }
  const std::string key = PartialKey(digest);
  auto active = std::make_shared<ActiveUpload>();
  active->cancel_stream = std::move(cancel_stream);
  active->written = offset;
  if (offset == 0) {
    {
      std::lock_guard lock(partial_mu_);
      ExpirePartialsLocked();
      if (auto it = kept_.find(key); it != kept_.end()) DropPartialLocked(it);
      active_.emplace(key, active);
    }
    const fs::path tmp = tmp_dir_ / absl::StrCat(digest.hash, ".", UniqueSuffix(), ".tmp");
    const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd < 0) {
      absl::Status error = ErrnoError("create", tmp);
      EndActive(key, active.get());
      return error;
    }
    return std::make_unique<BlobFileWriter>(this, digest, tmp, PathFor(digest), fd, 0, std::move(active));
  }
  KeptPartial claimed;
  bool took_over = false;  // the partial is a streaming upload's this one ended
  {
    std::unique_lock lock(partial_mu_);
    ExpirePartialsLocked();
    if (kept_.find(key) == kept_.end()) {
      // The upload this one resumes may still be streaming here: its
      // client's link broke, and this end has not heard yet. It may have
      // read a few more of the messages that crossed since QueryUpload
      // answered: its first `offset` bytes are the resume's prefix.
      std::shared_ptr<ActiveUpload> target;
      auto [begin, end] = active_.equal_range(key);
      for (auto it = begin; it != end; ++it) {
        if (it->second->written >= offset && (target == nullptr || it->second->written > target->written)) {
          target = it->second;
        }
      }
      if (target != nullptr) {
        took_over = true;
        auto released = [&] {
          if (kept_.count(key) != 0) return true;
          auto [b, e] = active_.equal_range(key);
          for (auto it = b; it != e; ++it) {
            if (it->second == target) return false;
          }
          return true;
        };
        target->preempted = true;
        if (!partial_changed_.wait_for(lock, std::chrono::seconds(2), released)) {
          // Blocked in a read on a dead link: end that stream. Its handler
          // cannot return while it is registered (EndActive takes this
          // lock), so its context is alive.
          if (target->cancel_stream) target->cancel_stream();
          partial_changed_.wait_for(lock, std::chrono::seconds(10), released);
        }
      }
    }
    auto it = kept_.find(key);
    const int64_t kept = it == kept_.end() ? 0 : it->second.bytes;
    if (kept != offset && !(took_over && kept > offset)) {
      return absl::FailedPreconditionError(absl::StrCat("offset: ", offset, " is not the length of the kept partial upload of blob ",
                                                        digest.hash, " (", kept, " bytes); query again or start at 0"));
    }
    claimed = it->second;
    kept_bytes_ -= claimed.bytes;
    kept_.erase(it);
    active_.emplace(key, active);
  }
  const int fd = ::open(claimed.path.c_str(), O_RDWR | O_CLOEXEC);  // read: the prefix is re-hashed
  if (fd < 0) {
    absl::Status error = ErrnoError("open", claimed.path);
    std::error_code ec;
    fs::remove(claimed.path, ec);
    EndActive(key, active.get());
    return error;
  }
  if (claimed.bytes > offset && ::ftruncate(fd, offset) != 0) {
    absl::Status error = ErrnoError("truncate", claimed.path);
    ::close(fd);
    std::error_code ec;
    fs::remove(claimed.path, ec);
    EndActive(key, active.get());
    return error;
  }
  auto writer = std::make_unique<BlobFileWriter>(this, digest, claimed.path, PathFor(digest), fd, offset,
                                                 std::move(active));
  if (absl::Status s = writer->HashPrefix(); !s.ok()) return s;  // the writer drops the file
  return writer;
}

absl::StatusOr<int64_t> BlobStore::PartialBytes(const BlobDigest& digest) {
  if (auto s = ValidateDigest("digest", digest.hash, digest.size_bytes); !s.ok()) return s;
  const std::string key = PartialKey(digest);
  std::lock_guard lock(partial_mu_);
  ExpirePartialsLocked();
  if (auto it = kept_.find(key); it != kept_.end()) return it->second.bytes;
  int64_t most = 0;
  auto [begin, end] = active_.equal_range(key);
  for (auto it = begin; it != end; ++it) most = std::max<int64_t>(most, it->second->written);
  return most;
}

int64_t BlobStore::kept_partial_bytes() {
  std::lock_guard lock(partial_mu_);
  ExpirePartialsLocked();
  return kept_bytes_;
}

void BlobStore::EndActive(const std::string& key, ActiveUpload* active) {
  std::lock_guard lock(partial_mu_);
  EndActiveLocked(key, active);
}

void BlobStore::EndActiveLocked(const std::string& key, ActiveUpload* active) {
  auto [begin, end] = active_.equal_range(key);
  for (auto it = begin; it != end; ++it) {
    if (it->second.get() == active) {
      active_.erase(it);
      partial_changed_.notify_all();
      return;
    }
  }
}

void BlobStore::KeepPartialAndEnd(const std::string& key, const fs::path& path, int64_t bytes,
                                  ActiveUpload* active) {
  std::lock_guard lock(partial_mu_);
  EndActiveLocked(key, active);
  ExpirePartialsLocked();
  partial_changed_.notify_all();
  std::error_code ec;
  auto existing = kept_.find(key);
  if (bytes <= 0 || bytes > partial_limits_.max_total_bytes ||
      (existing != kept_.end() && existing->second.bytes >= bytes)) {
    fs::remove(path, ec);
    return;
  }
  if (existing != kept_.end()) DropPartialLocked(existing);
  while (kept_bytes_ + bytes > partial_limits_.max_total_bytes && !kept_.empty()) {
    auto oldest = kept_.begin();
    for (auto it = kept_.begin(); it != kept_.end(); ++it) {
      if (it->second.kept_at < oldest->second.kept_at) oldest = it;
    }
    DropPartialLocked(oldest);
  }
  kept_[key] = KeptPartial{path, bytes, partial_limits_.now()};
  kept_bytes_ += bytes;
  spdlog::info("event=partial_upload_kept blob={} bytes={} kept_total_bytes={}", key, bytes, kept_bytes_);
}

void BlobStore::ExpirePartialsLocked() {
  const Clock::time_point now = partial_limits_.now();
  for (auto it = kept_.begin(); it != kept_.end();) {
    auto next = std::next(it);
    if (now - it->second.kept_at > partial_limits_.max_age) DropPartialLocked(it);
    it = next;
  }
}

void BlobStore::DropPartialLocked(std::map<std::string, KeptPartial>::iterator it) {
  std::error_code ec;
  fs::remove(it->second.path, ec);
  kept_bytes_ -= it->second.bytes;
  kept_.erase(it);
}

absl::StatusOr<bool> BlobStore::Put(const BlobDigest& digest, std::string_view bytes) {
  auto writer = NewWriter(digest);
  if (!writer.ok()) return writer.status();
  if (auto s = (*writer)->Append(bytes); !s.ok()) return s;
  return (*writer)->Commit();
}

bool BlobStore::Contains(const BlobDigest& digest) const {
  if (!IsSha256Hex(digest.hash)) return false;
  struct stat st {};
  if (::stat(PathFor(digest).c_str(), &st) != 0) return false;
  return st.st_size == digest.size_bytes;
}

absl::Status BlobStore::Verify(const BlobDigest& digest) const {
  if (auto s = ValidateDigest("digest", digest.hash, digest.size_bytes); !s.ok()) return s;
  const fs::path path = PathFor(digest);
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    return absl::NotFoundError(absl::StrCat("blob ", digest.ToString(), " not found"));
  }
  const int64_t mtime_ns = int64_t{st.st_mtim.tv_sec} * 1'000'000'000 + st.st_mtim.tv_nsec;
  {
    std::lock_guard lock(verified_mu_);
    auto it = verified_.find(digest.hash);
    if (it != verified_.end() && it->second == mtime_ns && st.st_size == digest.size_bytes) return absl::OkStatus();
  }
  auto digest_on_disk = DigestFile(path);
  if (!digest_on_disk.ok()) return digest_on_disk.status();
  if (digest_on_disk->hash == digest.hash && digest_on_disk->size_bytes == digest.size_bytes) {
    std::lock_guard lock(verified_mu_);
    verified_[digest.hash] = mtime_ns;
    return absl::OkStatus();
  }
  return Quarantine(digest, *digest_on_disk);
}

absl::Status BlobStore::Quarantine(const BlobDigest& digest, const BlobDigest& found) const {
  // Keep the evidence out of the store: a later upload or bake restores it.
  const fs::path path = PathFor(digest);
  std::error_code ec;
  fs::create_directories(quarantine_dir_, ec);
  fs::rename(path, quarantine_dir_ / absl::StrCat(digest.hash, ".", UniqueSuffix()), ec);
  if (!ec) total_bytes_ -= found.size_bytes;
  {
    std::lock_guard lock(verified_mu_);
    verified_.erase(digest.hash);
  }
  spdlog::error("event=blob_quarantined blob={} found_hash={} found_bytes={}", digest.ToString(), found.hash,
                found.size_bytes);
  return absl::DataLossError(absl::StrCat("blob ", digest.hash, ": stored bytes no longer match the digest (",
                                          found.size_bytes, " bytes hashing to ", found.hash, "); quarantined"));
}

absl::Status BlobStore::Read(const BlobDigest& digest, int64_t offset, int64_t limit, size_t chunk_bytes,
                             const std::function<bool(std::string_view, int64_t)>& sink) const {
  if (auto s = ValidateDigest("digest", digest.hash, digest.size_bytes); !s.ok()) return s;
  if (offset < 0 || limit < 0) {
    return absl::InvalidArgumentError(absl::StrCat("offset and limit must be >= 0, got ", offset, " and ", limit));
  }
  if (offset > digest.size_bytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("offset: ", offset, " is past the end of the blob (", digest.size_bytes, " bytes)"));
  }
  if (auto s = Verify(digest); !s.ok()) return s;
  const fs::path path = PathFor(digest);
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    if (errno == ENOENT) return absl::NotFoundError(absl::StrCat("blob ", digest.ToString(), " not found"));
    return ErrnoError("open", path);
  }
  struct stat st {};
  ::fstat(fd, &st);
  if (st.st_size != digest.size_bytes) {
    ::close(fd);
    return absl::DataLossError(absl::StrCat("blob ", digest.hash, " is ", st.st_size,
                                            " bytes on disk, its digest says ", digest.size_bytes));
  }
  int64_t end = digest.size_bytes;
  if (limit > 0 && offset + limit < end) end = offset + limit;
  // A whole read is hashed on the way: Verify trusts a blob whose file has
  // not changed since it was hashed, and bit rot changes no mtime. What
  // went out is then already sent, but the reader gets DATA_LOSS instead of
  // OK, and the blob is quarantined so the next request is a miss (a result
  // that needs it is baked again) rather than the same bad bytes.
  const bool whole = offset == 0 && end == digest.size_bytes;
  Sha256 hasher;
  // No larger than what is read: ReadAll's 1 MiB chunk for a 20 KB blob
  // would zero a megabyte per call (BatchReadBlobs reads dozens a call).
  std::vector<char> buf(static_cast<size_t>(std::clamp<int64_t>(end - offset, 1, std::max<size_t>(chunk_bytes, 1))));
  int64_t pos = offset;
  absl::Status status;
  bool stopped = false;
  while (pos < end) {
    const size_t want = static_cast<size_t>(std::min<int64_t>(end - pos, static_cast<int64_t>(buf.size())));
    const ssize_t n = ::pread(fd, buf.data(), want, pos);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      status = n < 0 ? ErrnoError("read", path) : absl::DataLossError(absl::StrCat("blob ", digest.hash, " is truncated"));
      break;
    }
    const std::string_view chunk(buf.data(), static_cast<size_t>(n));
    if (whole) hasher.Update(chunk);
    if (!sink(chunk, pos)) {
      stopped = true;
      break;
    }
    pos += n;
  }
  ::close(fd);
  if (whole && status.ok() && !stopped) {
    if (const std::string hash = hasher.FinishHex(); hash != digest.hash) {
      return Quarantine(digest, {hash, digest.size_bytes});
    }
  }
  return status;
}

absl::StatusOr<std::string> BlobStore::ReadAll(const BlobDigest& digest) const {
  std::string out;
  out.reserve(static_cast<size_t>(std::max<int64_t>(digest.size_bytes, 0)));
  auto s = Read(digest, 0, 0, 1 << 20, [&out](std::string_view chunk, int64_t) {
    out.append(chunk);
    return true;
  });
  if (!s.ok()) return s;  // Read hashed the whole blob
  return out;
}

}  // namespace impostor
