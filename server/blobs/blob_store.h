// Content-addressed blob store on a local directory.
//
// Layout under `root`:
//   cas/ab/abcdef...   one file per blob, named by its SHA-256 hex, in a
//                      folder named by the hash's first two characters
//   tmp/               uploads in progress and kept partial uploads; files
//                      older than an hour are removed when the store opens
// A blob becomes visible only after all its bytes were written to a
// temporary file, hashed and size-checked against the digest, fsynced, and
// renamed into cas/ (then the folder is fsynced too), so a reader never sees
// a partial or wrong blob, even across a crash.
//
// Partial uploads: an upload whose stream ended early (Writer::Keep) leaves
// its bytes in tmp/ for a while, so that the same blob's next upload can
// resume after them (NewWriter with an offset) instead of starting over.
// Kept partials are bounded (PartialUploadLimits: total bytes, age); the
// oldest goes first. The resumed upload re-hashes the kept bytes and is
// verified on Commit exactly as a fresh one. The index of kept partials is
// this process's: a resume that reaches another server sharing the
// directory (issue 15) finds none and starts over.
//
// Thread-safety: all methods may be called from any thread. Concurrent
// uploads of the same blob each write their own temporary file; the first
// rename wins and the others find the blob present. At most one partial is
// kept per blob (the longest); a resume claims it whole, so two resumes of
// one blob never share a file.
#ifndef IMPOSTOR_SERVER_BLOBS_BLOB_STORE_H_
#define IMPOSTOR_SERVER_BLOBS_BLOB_STORE_H_

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "common/util/sha256.h"

namespace impostor {

// How much of interrupted uploads a BlobStore keeps for a resume.
struct PartialUploadLimits {
  // Bytes of all kept partials together; the oldest are dropped to make
  // room, and a partial larger than this is not kept. 0 keeps none.
  int64_t max_total_bytes = int64_t{4} << 30;
  // A partial not resumed within this long is dropped.
  std::chrono::seconds max_age{3600};
  // The clock that ages partials (tests give a fake one).
  std::function<std::chrono::steady_clock::time_point()> now = [] { return std::chrono::steady_clock::now(); };
};

class BlobStore {
 public:
  // Largest blob accepted, bytes.
  static constexpr int64_t kDefaultMaxBlobBytes = int64_t{2} << 30;

  using Clock = std::chrono::steady_clock;
  using PartialUploadLimits = impostor::PartialUploadLimits;

  // Creates the folders if needed and removes leftover temporary files.
  // INTERNAL naming the path when the directory cannot be used.
  static absl::StatusOr<std::unique_ptr<BlobStore>> Open(const std::filesystem::path& root,
                                                         int64_t max_blob_bytes = kDefaultMaxBlobBytes,
                                                         PartialUploadLimits partial_limits = {});

  // Streams one upload into a temporary file. Destroying a writer that was
  // neither committed nor kept removes its temporary file. One thread at a
  // time.
  class Writer {
   public:
    virtual ~Writer() = default;
    // INVALID_ARGUMENT when more bytes arrive than the digest's size.
    virtual absl::Status Append(std::string_view data) = 0;
    // Verifies hash and size, syncs and publishes the blob. Returns true when
    // the blob was already present (the upload is discarded).
    // INVALID_ARGUMENT on a hash or size mismatch (saying both values).
    virtual absl::StatusOr<bool> Commit() = 0;
    // Bytes of the blob written so far, a resumed prefix included.
    virtual int64_t written() const = 0;
    // The stream ended early: keeps the bytes written so far for a resume,
    // within the store's PartialUploadLimits. The writer is done after it.
    virtual void Keep() = 0;
    // True once another upload of the blob resumed after this writer's
    // bytes (NewWriter with an offset): the caller should stop appending
    // and Keep() at once.
    virtual bool preempted() const = 0;
  };

  // A writer for `digest` whose first byte is the blob's byte `offset`:
  // 0 starts afresh (dropping a kept partial of the blob); any other offset
  // resumes the kept partial, which must hold exactly `offset` bytes. When
  // none is kept, an upload of the blob still streaming into this store
  // that has written at least `offset` bytes (its client's link broke and
  // the server has not noticed yet; QueryUpload reported its progress) is
  // taken over: asked to stop (preempted()), after two seconds cancelled
  // through `cancel_stream` (the caller's hook to end that upload's stream;
  // may be empty), and its first `offset` bytes are resumed.
  // INVALID_ARGUMENT for a malformed digest, one over the size limit, or an
  // offset outside 0..size_bytes; FAILED_PRECONDITION when `offset` is not
  // the kept partial's length (the message names both).
  absl::StatusOr<std::unique_ptr<Writer>> NewWriter(const BlobDigest& digest, int64_t offset = 0,
                                                    std::function<void()> cancel_stream = {});

  // Bytes of `digest` a resume may start after: a kept partial's, else the
  // most an upload still streaming into this store has written; 0 when
  // none. INVALID_ARGUMENT for a malformed digest.
  absl::StatusOr<int64_t> PartialBytes(const BlobDigest& digest);
  // Bytes of all kept partials (tests and metrics).
  int64_t kept_partial_bytes();

  // Writes a whole blob; same outcomes as NewWriter + Append + Commit.
  absl::StatusOr<bool> Put(const BlobDigest& digest, std::string_view bytes);

  // True when the blob is present with the right size (a stat; no hashing).
  bool Contains(const BlobDigest& digest) const;

  // Re-hashes the blob unless it was verified since its file last changed.
  // A blob whose bytes no longer match its digest is moved to quarantine/
  // (never served again) and DATA_LOSS is returned; NOT_FOUND when absent.
  absl::Status Verify(const BlobDigest& digest) const;

  // Calls `sink` with consecutive chunks (at most `chunk_bytes` each) of the
  // blob from `offset`, at most `limit` bytes (0 = to the end); stops early
  // when `sink` returns false. The blob is verified first (see Verify), so no
  // corrupt byte is ever passed on. NOT_FOUND when absent; INVALID_ARGUMENT
  // for an offset past the end or a negative offset/limit; DATA_LOSS when the
  // stored bytes no longer match the digest.
  absl::Status Read(const BlobDigest& digest, int64_t offset, int64_t limit, size_t chunk_bytes,
                    const std::function<bool(std::string_view chunk, int64_t offset)>& sink) const;

  // The whole blob, its hash verified. Same errors as Read; DATA_LOSS when
  // the bytes no longer hash to the digest. A whole Read (offset 0, to the
  // end) hashes what it sends, and quarantines a blob whose bytes changed
  // since it was last verified (bit rot keeps the file's mtime).
  absl::StatusOr<std::string> ReadAll(const BlobDigest& digest) const;

  // A blob file as found on disk.
  struct StoredBlob {
    std::string hash;
    int64_t size_bytes = 0;
    int64_t mtime_ns = 0;  // when it was published
  };
  // Every blob in the store (a directory scan).
  std::vector<StoredBlob> List() const;
  // Deletes a blob; OK if it is already gone.
  absl::Status Remove(const std::string& hash);
  // Bytes of all published blobs, kept current by the store itself.
  int64_t total_bytes() const { return total_bytes_.load(); }
  // Sets total_bytes() to the sum of `scan` (a List() answer) and returns
  // it. Servers sharing this directory (issue 15) publish and remove blobs
  // that this process's own count never sees; the one that evicts recounts
  // before it decides.
  int64_t Recount(const std::vector<StoredBlob>& scan);

  std::filesystem::path PathFor(const BlobDigest& digest) const;
  const std::filesystem::path& root() const { return root_; }

 private:
  // One upload streaming into this store, seen by resumes of its blob.
  struct ActiveUpload {
    std::atomic<int64_t> written{0};
    std::atomic<bool> preempted{false};
    std::function<void()> cancel_stream;
  };
  // A kept partial upload: the first `bytes` bytes of its blob in `path`.
  struct KeptPartial {
    std::filesystem::path path;
    int64_t bytes = 0;
    Clock::time_point kept_at;
  };
  friend class BlobFileWriter;

  BlobStore(std::filesystem::path root, int64_t max_blob_bytes, PartialUploadLimits partial_limits);
  static std::string PartialKey(const BlobDigest& digest) { return digest.ToString(); }
  // Called by writers: register while streaming; hand over (keep) or drop
  // the file when done.
  void EndActive(const std::string& key, ActiveUpload* active);
  // Keeps `path` as the partial of `key` and ends `active`, under one hold
  // of partial_mu_: a resume waiting on `active` must see the partial when
  // it sees the upload gone, or it refuses an offset it could have resumed.
  void KeepPartialAndEnd(const std::string& key, const std::filesystem::path& path, int64_t bytes,
                         ActiveUpload* active);
  void EndActiveLocked(const std::string& key, ActiveUpload* active) ABSL_EXCLUSIVE_LOCKS_REQUIRED(partial_mu_);
  // Drops kept partials past max_age. Needs partial_mu_.
  void ExpirePartialsLocked() ABSL_EXCLUSIVE_LOCKS_REQUIRED(partial_mu_);
  void DropPartialLocked(std::map<std::string, KeptPartial>::iterator it) ABSL_EXCLUSIVE_LOCKS_REQUIRED(partial_mu_);
  void AddPublished(int64_t bytes) { total_bytes_ += bytes; }
  // Moves the blob of `digest`, found to hold `found`, to quarantine/ and
  // forgets that it was verified; returns the DATA_LOSS that says so.
  absl::Status Quarantine(const BlobDigest& digest, const BlobDigest& found) const;

  const std::filesystem::path root_;
  const std::filesystem::path cas_dir_;
  const std::filesystem::path tmp_dir_;
  const std::filesystem::path quarantine_dir_;
  const int64_t max_blob_bytes_;
  mutable std::atomic<int64_t> total_bytes_{0};  // quarantine in const Verify updates it

  // hash -> modification time (ns) of the file when its content last hashed
  // to the digest. Lets reads skip re-hashing an unchanged blob.
  mutable std::mutex verified_mu_;
  mutable std::map<std::string, int64_t> verified_ ABSL_GUARDED_BY(verified_mu_);

  const PartialUploadLimits partial_limits_;
  std::mutex partial_mu_;
  std::condition_variable partial_changed_;  // a partial kept or an upload ended
  // Keyed by PartialKey (hash/size).
  std::map<std::string, KeptPartial> kept_ ABSL_GUARDED_BY(partial_mu_);
  int64_t kept_bytes_ ABSL_GUARDED_BY(partial_mu_) = 0;
  std::multimap<std::string, std::shared_ptr<ActiveUpload>> active_ ABSL_GUARDED_BY(partial_mu_);
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_BLOBS_BLOB_STORE_H_
