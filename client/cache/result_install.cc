#include "client/cache/result_install.h"

#include <fcntl.h>
#include <stdlib.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <set>
#include <system_error>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/local_io_error.h"
#include "client/result_fetch.h"
#include "client/sdk_log.h"
#include "common/manifest_json.h"

namespace impostor::sdk {
namespace {

namespace fs = std::filesystem;

// Removes a staging directory unless released (installed).
class StagingDir {
 public:
  explicit StagingDir(fs::path path) : path_(std::move(path)) {}
  ~StagingDir() {
    if (!path_.empty()) {
      std::error_code ec;
      fs::remove_all(path_, ec);
    }
  }
  const fs::path& path() const { return path_; }
  void Release() { path_.clear(); }

 private:
  fs::path path_;
};

absl::Status WriteSynced(const fs::path& path, const std::string& text) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return LocalIoError("cannot create", path, errno);
  std::string_view data = text;
  while (!data.empty()) {
    const ssize_t n = ::write(fd, data.data(), data.size());
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const int err = errno;
      ::close(fd);
      return LocalIoError("cannot write", path, err);
    }
    data.remove_prefix(static_cast<size_t>(n));
  }
  if (::fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    return LocalIoError("cannot sync", path, err);
  }
  if (::close(fd) != 0) return LocalIoError("cannot close", path, errno);
  return absl::OkStatus();
}

EntryRecord RecordOf(const std::string& key, const v1::Manifest& manifest) {
  EntryRecord record;
  record.key = key;
  record.layout = std::string(LayoutJsonName(manifest.layout()));
  record.frames = manifest.frames();
  record.resolution = manifest.resolution();
  for (const v1::MapFile& map : manifest.maps()) {
    EntryFile f;
    f.semantic = map.semantic();
    f.name = map.file();
    f.sha256 = map.digest().hash();
    f.size_bytes = map.digest().size_bytes();
    f.width = map.width();
    f.height = map.height();
    f.format = map.format();
    record.files.push_back(std::move(f));
  }
  EntryFile m;
  m.semantic = "manifest";
  m.name = kManifestFileName;
  m.sha256 = manifest.manifest_json().hash();
  m.size_bytes = manifest.manifest_json().size_bytes();
  m.format = "json";
  record.files.push_back(std::move(m));
  return record;
}

// DownloadAndInstall, which gives back the space of `partials` (those this
// call completed) when the disk is full.
absl::StatusOr<InstallOutcome> Install(Transport& transport, const CacheLayout& layout, const std::string& key,
                                       const DownloadHooks& hooks, const std::atomic<bool>* cancel,
                                       std::vector<fs::path>& partials) {
  absl::StatusOr<v1::Manifest> manifest = transport.GetResult(key);
  if (!manifest.ok()) return manifest.status();
  if (absl::Status s = CheckManifestFiles(*manifest); !s.ok()) {
    return absl::InternalError(
        absl::StrCat("server ", transport.server(), " sent a bad result for ", key, ": ", s.message()));
  }
  if (!manifest->cache_key().empty() && manifest->cache_key() != key) {
    return absl::DataLossError(absl::StrCat("server ", transport.server(), " answered ", key,
                                            " with the result of ", manifest->cache_key().substr(0, 64)));
  }

  InstallOutcome outcome;
  outcome.record = RecordOf(key, *manifest);
  std::set<fs::path> fetched;
  for (const EntryFile& f : outcome.record.files) {
    v1::Digest digest;
    digest.set_hash(f.sha256);
    digest.set_size_bytes(f.size_bytes);
    const fs::path partial = layout.PartialPath(f.sha256, f.size_bytes);
    // One blob under several names (a LOD chain's levels may share bytes)
    // is fetched once and linked under each; counted once, not as resumed.
    if (fetched.insert(partial).second) {
      absl::StatusOr<PartialOutcome> got = DownloadToPartial(transport, digest, partial, hooks, cancel);
      if (!got.ok()) return got.status();
      outcome.bytes_downloaded += got->bytes_downloaded;
      outcome.bytes_resumed += got->bytes_resumed;
    }
    partials.push_back(partial);
  }

  std::string pattern = (layout.StagingDir() / absl::StrCat(key, ".XXXXXX")).string();
  if (::mkdtemp(pattern.data()) == nullptr) return LocalIoError("cannot create a directory in", layout.StagingDir(), errno);
  StagingDir staging(pattern);
  // Hard links: the partial file becomes the installed file without a copy,
  // and two maps with equal bytes may share one partial.
  for (size_t i = 0; i < partials.size(); ++i) {
    const fs::path target = staging.path() / outcome.record.files[i].name;
    if (::link(partials[i].c_str(), target.c_str()) != 0) {
      return LocalIoError(absl::StrCat("cannot link ", partials[i].string(), " to"), target, errno);
    }
  }
  // Identities are those of the linked files, which the partials' removal
  // below does not change.
  if (absl::Status s = RecordFileIdentities(staging.path(), outcome.record); !s.ok()) return s;
  if (absl::Status s = WriteSynced(staging.path() / kEntryRecordName, EntryRecordToJson(outcome.record)); !s.ok()) {
    return s;
  }
  if (absl::Status s = SyncDir(staging.path()); !s.ok()) return s;

  const fs::path entry = layout.EntryDir(key);
  if (::rename(staging.path().c_str(), entry.c_str()) != 0) {
    const int err = errno;
    if (err != EEXIST && err != ENOTEMPTY) return LocalIoError(absl::StrCat("cannot install ", key, " as"), entry, err);
    // Someone (another process) installed it first; theirs is as good.
    absl::StatusOr<EntryRecord> theirs = ReadEntryRecord(entry);
    if (!theirs.ok()) {
      return absl::InternalError(absl::StrCat("cannot install ", key, ": ", entry.string(),
                                              " exists and is unreadable: ", theirs.status().message()));
    }
    outcome.record = std::move(*theirs);
    outcome.raced = true;
  } else {
    staging.Release();
    if (absl::Status s = SyncDir(layout.EntriesDir()); !s.ok()) return s;
  }
  for (const fs::path& partial : partials) {
    std::error_code ec;
    fs::remove(partial, ec);
  }
  SdkLog().debug("cache: installed {} ({} bytes downloaded, {} resumed)", key, outcome.bytes_downloaded,
                 outcome.bytes_resumed);
  return outcome;
}

}  // namespace

absl::StatusOr<InstallOutcome> DownloadAndInstall(Transport& transport, const CacheLayout& layout,
                                                  const std::string& key, const DownloadHooks& hooks,
                                                  const std::atomic<bool>* cancel) {
  std::vector<fs::path> partials;
  absl::StatusOr<InstallOutcome> outcome = Install(transport, layout, key, hooks, cancel, partials);
  if (!outcome.ok() && IsLocalDiskFull(outcome.status())) {
    // Complete partial files would hold the very space that is missing,
    // and a result is useless without all its files: nothing stays behind.
    for (const fs::path& partial : partials) {
      std::error_code ec;
      fs::remove(partial, ec);
    }
  }
  return outcome;
}

}  // namespace impostor::sdk
