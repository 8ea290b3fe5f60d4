// A release tree on this host's disk (client/delivery/release_format.md), as
// --http-releases serves it: which request paths name one of its files
// (ParseReleasePath), opening such a file without leaving the tree, and
// checking an immutable file's bytes against the digest it is named by
// (ReleaseTree::Verify). No HTTP here: release_response.h answers requests
// with it.
//
// Integrity: a blob or catalog is hashed the first time it is asked for,
// and whatever the hash said is remembered for that file's identity (path,
// device, inode, size, mtime), so a file is read for its check once, not
// once per download; a file replaced or touched since is checked again.
// Concurrent first requests for one file share a single verification read
// (single flight per path): a popular new release asked for by a thousand
// clients at once is hashed once. A mismatch is logged once
// (event=release_blob_corrupt) and remembered too, so asking again for a
// corrupt file costs no read.
#ifndef IMPOSTOR_SERVER_HTTP_RELEASE_FILES_H_
#define IMPOSTOR_SERVER_HTTP_RELEASE_FILES_H_

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <future>
#include <list>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"

namespace impostor {

enum class ReleaseFileKind { kBlob, kCatalog, kChannel };

// "blob", "catalog", "channel".
std::string_view ReleaseFileKindName(ReleaseFileKind kind);

// A file of a release tree, named by a request path.
struct ReleasePath {
  ReleaseFileKind kind = ReleaseFileKind::kBlob;
  // Blobs and catalogs: the 64 lowercase hex SHA-256 of the file's bytes;
  // channels: the channel's name (without ".json").
  std::string name;
  // Under the tree's root, "/"-separated: "v1/blobs/sha256/ab/ab12...",
  // "v1/catalogs/sha256/ab/ab12...", "v1/channels/nightly.json".
  std::string relative;

  // Blobs and catalogs never change their bytes; channels do.
  bool immutable() const { return kind != ReleaseFileKind::kChannel; }
  friend bool operator==(const ReleasePath&, const ReleasePath&) = default;
};

// `path` is a request path below the URL prefix, exactly as sent (not
// percent-decoded, no query), e.g. "v1/channels/nightly.json". The file it
// names when it is exactly one of
//   v1/blobs/sha256/<hh>/<64 lowercase hex>      <hh> = the hex's first two
//   v1/catalogs/sha256/<hh>/<64 lowercase hex>
//   v1/channels/<[A-Za-z0-9][A-Za-z0-9._-]{0,63}>.json
// and nullopt for anything else: other folders, upper-case or short hex,
// a wrong <hh>, "." or ".." segments, empty segments, a trailing "/", and
// any "%" escape (an encoded "/" or "." never names a file). Pure.
std::optional<ReleasePath> ParseReleasePath(std::string_view path);

// What identifies one version of a file: a file replaced by a rename (a new
// inode) or rewritten in place (a new mtime or size) is another version.
struct ReleaseFileIdentity {
  uint64_t device = 0;
  uint64_t inode = 0;
  int64_t size_bytes = 0;
  int64_t mtime_ns = 0;
  friend bool operator==(const ReleaseFileIdentity&, const ReleaseFileIdentity&) = default;
};

// An open regular file of a release tree; closes it on destruction.
// Movable, not copyable. Its methods may be called from any thread (reads
// are positional), e.g. by the HTTP library's writer after the handler
// that opened it returned.
class OpenReleaseFile {
 public:
  OpenReleaseFile(int fd, ReleaseFileIdentity identity) : fd_(fd), identity_(identity) {}
  ~OpenReleaseFile();
  OpenReleaseFile(OpenReleaseFile&& other) noexcept;
  OpenReleaseFile& operator=(OpenReleaseFile&& other) noexcept;
  OpenReleaseFile(const OpenReleaseFile&) = delete;
  OpenReleaseFile& operator=(const OpenReleaseFile&) = delete;

  // As of when it was opened.
  const ReleaseFileIdentity& identity() const { return identity_; }
  int64_t size_bytes() const { return identity_.size_bytes; }
  // As of now (fstat); all zero when that fails.
  ReleaseFileIdentity CurrentIdentity() const;

  // Reads up to `length` bytes at `offset` into `out` (replacing its
  // contents); fewer only at the end of the file (which is then empty).
  // INTERNAL with errno's text when the read fails.
  absl::Status ReadAt(int64_t offset, size_t length, std::string& out) const;
  // The whole file: FAILED_PRECONDITION when it is over `max_bytes`,
  // INTERNAL when a read fails.
  absl::StatusOr<std::string> ReadAll(int64_t max_bytes) const;

 private:
  int fd_ = -1;
  ReleaseFileIdentity identity_;
};

// One release tree (the directory that holds v1/), opened at startup: it
// keeps its root's path and what it learnt about the immutable files' bytes;
// files are opened afresh per request, so a publish is seen at once.
//
// Thread-safety: every method may be called from any thread (the HTTP
// library's handler threads).
class ReleaseTree {
 public:
  struct Options {
    // Files whose check is remembered (verified or found corrupt), least
    // recently asked for forgotten first (>= 1). A forgotten file is hashed
    // again when next asked for. 65536 entries take about 20 MB.
    size_t max_remembered = 65536;
    // For tests: called with `true` on the thread that is about to read a
    // file for its check, and with `false` on each thread about to wait for
    // a check in progress on another thread, with the file's relative path.
    std::function<void(bool reads, std::string_view relative)> on_verify;
  };

  // INVALID_ARGUMENT naming the path when `root` is not a directory or has
  // no v1/ directory (not a release tree `impostor publish` wrote).
  static absl::StatusOr<std::unique_ptr<ReleaseTree>> Open(const std::filesystem::path& root, Options options);
  static absl::StatusOr<std::unique_ptr<ReleaseTree>> Open(const std::filesystem::path& root) {
    return Open(root, Options{});
  }

  // Opens the file `path` names. Every folder on the way and the file itself
  // are opened without following symbolic links, so a link anywhere below
  // the root (one pointing out of the tree or not) is never followed; the
  // root itself may be a link. NOT_FOUND when the file or a folder on the
  // way is absent, is a link, or is not a regular file or a folder;
  // INTERNAL naming the relative path and errno's text for other failures
  // (a permission error, I/O).
  absl::StatusOr<OpenReleaseFile> OpenFile(const ReleasePath& path) const;

  // For an immutable file, opened by OpenFile(path): OK when its bytes hash
  // to the name it has. Reads the file only when this version of it (its
  // identity) has not been checked yet, or was forgotten; concurrent calls
  // for one path share one read. DATA_LOSS naming the path, the digest the
  // name says and the one the bytes have (the log line is written once per
  // version); UNAVAILABLE when the file changed while it was read (a retry
  // checks it again); INTERNAL when a read failed. Failures other than
  // DATA_LOSS are not remembered.
  absl::Status Verify(const ReleasePath& path, const OpenReleaseFile& file);

  const std::filesystem::path& root() const { return root_; }
  // How many times a file was read for its check (for tests).
  int64_t verification_reads() const;

 private:
  // A finished check of one version of a file.
  struct Outcome {
    ReleaseFileIdentity identity;
    absl::Status status;       // OK, DATA_LOSS or what stopped the read
    std::string actual_hex;    // what the bytes hash to (empty when the read failed)
  };
  struct Remembered {
    Outcome outcome;
    std::list<std::string>::iterator lru;  // into lru_
  };

  ReleaseTree(std::filesystem::path root, Options options) : root_(std::move(root)), options_(std::move(options)) {}
  // Reads and hashes `file` (the caller leads the path's single flight).
  Outcome Check(const ReleasePath& path, const OpenReleaseFile& file);
  void Remember(const std::string& relative, const Outcome& outcome) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  absl::Status StatusOf(const ReleasePath& path, const Outcome& outcome) const;

  const std::filesystem::path root_;
  const Options options_;
  mutable absl::Mutex mu_;
  // By relative path: the last check's outcome (bounded: options_.max_remembered).
  std::map<std::string, Remembered, std::less<>> remembered_ ABSL_GUARDED_BY(mu_);
  // Relative paths, most recently asked for first.
  std::list<std::string> lru_ ABSL_GUARDED_BY(mu_);
  // Checks in progress, by relative path: the leader's promise fulfils it.
  std::map<std::string, std::shared_future<Outcome>, std::less<>> in_flight_ ABSL_GUARDED_BY(mu_);
  int64_t verification_reads_ ABSL_GUARDED_BY(mu_) = 0;
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_HTTP_RELEASE_FILES_H_
