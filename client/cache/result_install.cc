#include "client/cache/result_install.h"

#include <fcntl.h>
#include <stdlib.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <system_error>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "client/base/early_sync.h"
#include "client/base/local_io_error.h"
#include "client/cache/prefetched_blobs.h"
#include "client/transfer/farm_http_fetch.h"
#include "client/transfer/result_fetch.h"
#include "client/transport/rpc_error.h"
#include "client/base/sdk_log.h"
#include "common/manifest/manifest_json.h"

namespace impostor::sdk {
namespace {

namespace fs = std::filesystem;

// How often in a row a blob's partial file may vanish under this install
// (FetchBlob's ABORTED), or another process's entry of the key be evicted
// before we could pin it, before the install gives up.
constexpr int kMaxRetries = 8;

// How many of a result's blob files an install keeps open from their
// download to its sync and cleanup (BlobOutcome::file); the rest are opened
// again by name. A release's asset has a handful of files; a farm result
// with its quality pass has ~40, and a game runs up to
// max_parallel_downloads installs at once under a limit of open files.
constexpr size_t kMaxFilesKeptOpen = 8;

double AgeSeconds(const struct stat& st) {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count() -
         (static_cast<double>(st.st_mtim.tv_sec) + st.st_mtim.tv_nsec * 1e-9);
}

// An install's staging directory: locked (flock on the directory) while the
// install runs, so that garbage collection in any process leaves it alone
// however long the download takes; removed with everything in it unless
// released (installed).
class Staging {
 public:
  static absl::StatusOr<std::unique_ptr<Staging>> Create(const CacheLayout& layout, const std::string& key) {
    std::string pattern = (layout.StagingDir() / absl::StrCat(key, ".XXXXXX")).string();
    if (::mkdtemp(pattern.data()) == nullptr) {
      return LocalIoError("cannot create a directory in", layout.StagingDir(), errno);
    }
    auto staging = std::unique_ptr<Staging>(new Staging(pattern));
    staging->fd_ = ::open(pattern.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    // Garbage collection looks at old directories only, so a fresh one is
    // never held by it: the lock is free.
    if (staging->fd_ < 0 || ::flock(staging->fd_, LOCK_EX | LOCK_NB) != 0) {
      return LocalIoError("cannot lock", staging->path_, errno);
    }
    return staging;
  }
  ~Staging() {
    if (!path_.empty()) {
      std::error_code ec;
      fs::remove_all(path_, ec);
    }
    if (fd_ >= 0) ::close(fd_);
  }
  Staging(const Staging&) = delete;
  Staging& operator=(const Staging&) = delete;
  const fs::path& path() const { return path_; }
  void Release() { path_.clear(); }

 private:
  explicit Staging(fs::path path) : path_(std::move(path)) {}
  fs::path path_;
  int fd_ = -1;
};

// A shared partial file this install linked from; deleted at the end by
// whoever uses it last.
struct UsedPartial {
  fs::path path;
  FileIdentity identity;
  UniqueFd file;  // kept open since its download, or not (kMaxFilesKeptOpen)
};

struct Pinned {
  EntryRecord record;
  std::unique_ptr<EntryLock> lock;
};

// The entry of `key` another install put in place, pinned before its record
// is read. NOT_FOUND when there is none (or it was evicted meanwhile).
absl::StatusOr<Pinned> PinInstalled(const CacheLayout& layout, const std::string& key) {
  const fs::path entry = layout.EntryDir(key);
  absl::StatusOr<std::unique_ptr<EntryLock>> lock = EntryLock::Shared(entry);
  if (!lock.ok()) return lock.status();
  absl::StatusOr<EntryRecord> record = ReadEntryRecord(entry);
  if (!record.ok()) {
    if (record.status().code() == absl::StatusCode::kNotFound) return record.status();
    return absl::InternalError(absl::StrCat("cannot install ", key, ": ", entry.string(),
                                            " exists and is unreadable: ", record.status().message()));
  }
  if (record->key != key) {
    return absl::InternalError(
        absl::StrCat("cannot install ", key, ": ", entry.string(), " exists and holds ", record->key));
  }
  return Pinned{std::move(*record), std::move(*lock)};
}

// Gives up `used` (closing what it kept open).
void RemoveUsedPartials(std::vector<UsedPartial>& used) {
  for (UsedPartial& u : used) {
    if (u.file.valid()) {
      (void)RemoveOpenPartialIfUnused(u.path, std::move(u.file), u.identity);
    } else {
      (void)RemovePartialIfUnused(u.path, &u.identity);
    }
  }
  used.clear();
}

// A blob file staged for a result: its first name in the staging directory,
// and the descriptor its download kept open (-1: opened by name).
struct StagedFile {
  fs::path path;
  int fd = -1;
};

// Waits until every file staged for a result is on disk. The downloads
// started their writeback as each blob finished, so this mostly waits for
// what is in flight, and the files' syncs share one journal commit: one per
// result, where a sync per file cost one commit each (what a fetch of many
// small files paid, on a loaded disk most of all).
absl::Status SyncStagedFiles(const std::vector<StagedFile>& files) {
  for (const StagedFile& file : files) {
    if (file.fd >= 0) {
      if (::fdatasync(file.fd) != 0) return LocalIoError("cannot sync", file.path, errno);
      continue;
    }
    const UniqueFd fd(::open(file.path.c_str(), O_RDONLY | O_CLOEXEC));
    if (!fd.valid()) return LocalIoError("cannot open", file.path, errno);
    if (::fdatasync(fd.get()) != 0) return LocalIoError("cannot sync", file.path, errno);
  }
  return absl::OkStatus();
}

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

// The farm's listing of `key`, checked.
absl::StatusOr<v1::Manifest> FarmListing(Transport& transport, const std::string& key, const CancelSource* cancel) {
  absl::StatusOr<v1::Manifest> manifest = transport.GetResult(key, cancel);
  if (!manifest.ok()) return manifest.status();
  if (!manifest->cache_key().empty() && manifest->cache_key() != key) {
    return absl::DataLossError(absl::StrCat("server ", transport.server(), " answered ", key,
                                            " with the result of ", manifest->cache_key().substr(0, 64)));
  }
  return manifest;
}

// Whether a failure of one source should stop the install rather than move
// on to the next source: cancellation and local disk trouble are the same
// whichever source is asked.
bool StopsInstall(const absl::Status& status) { return absl::IsCancelled(status) || IsLocalFailure(status); }

// How a front end is asked for one of a result's files: by its name.
using FileReader = std::function<absl::Status(const std::string& file_name, const v1::Digest& digest, int64_t offset,
                                              Sha256& hash, const std::function<absl::Status(std::string_view)>& sink,
                                              const CancelSource* cancel)>;

// A BlobReader over `read_file` for the blobs of `listing`: a blob is asked
// for under a file name it has there (one blob may have several).
BlobReader ReaderByFileName(const v1::Manifest& listing, FileReader read_file) {
  auto names = std::make_shared<std::map<std::string, std::string>>();  // hash -> a file name of it
  for (const v1::MapFile& map : listing.maps()) names->emplace(map.digest().hash(), map.file());
  names->emplace(listing.manifest_json().hash(), kManifestFileName);
  return [names, key = listing.cache_key(), read_file = std::move(read_file)](
             const v1::Digest& digest, int64_t offset, Sha256& hash,
             const std::function<absl::Status(std::string_view)>& sink, const CancelSource* c) -> absl::Status {
    auto it = names->find(digest.hash());
    if (it == names->end()) return absl::NotFoundError(absl::StrCat("blob ", digest.hash(), " is no file of ", key));
    return read_file(it->second, digest, offset, hash, sink, c);
  };
}

// InstallFromSources; `used` gets the shared partial files linked from, for
// the caller to give back their space when the disk is full.
absl::StatusOr<InstallOutcome> Install(const InstallPlan& plan, const CacheLayout& layout, const std::string& key,
                                       const DownloadHooks& hooks, const CancelSource* cancel,
                                       std::vector<UsedPartial>& used) {
  const v1::Manifest* manifest = &plan.listing;
  if (absl::Status s = CheckManifestFiles(*manifest); !s.ok()) {
    return absl::InternalError(absl::StrCat(plan.listing_source, " sent a bad result for ", key, ": ", s.message()));
  }
  if (plan.sources.empty()) return absl::InternalError(absl::StrCat("no source to install ", key, " from"));

  InstallOutcome outcome;
  outcome.record = RecordOf(key, *manifest);
  // Another install that finished meanwhile: its entry is used, and the
  // partials this one used are cleaned up.
  auto use_theirs = [&](Pinned theirs) {
    outcome.record = std::move(theirs.record);
    outcome.pin = std::move(theirs.lock);
    outcome.raced = true;
    RemoveUsedPartials(used);
    SdkLog().debug("cache: {} was installed by another download ({} bytes downloaded here, {} resumed)", key,
                   outcome.bytes_downloaded, outcome.bytes_resumed);
    return std::move(outcome);
  };

  absl::StatusOr<std::unique_ptr<Staging>> staging = Staging::Create(layout, key);
  if (!staging.ok()) return staging.status();
  const fs::path& staged = (*staging)->path();
  // Each blob once, in manifest order, with every name it goes under (one
  // blob under several names, as a LOD chain's levels may share bytes, is
  // fetched once and linked under each).
  struct Blob {
    v1::Digest digest;
    fs::path partial;
    std::vector<fs::path> links;
    UniqueFd own_file;  // kept open, when not shared (FetchPrivately's)
    int fd = -1;        // kept open: own_file, or its UsedPartial's
  };
  std::vector<Blob> blobs;
  for (const EntryFile& f : outcome.record.files) {
    const fs::path partial = layout.PartialPath(f.sha256, f.size_bytes);
    auto it = std::find_if(blobs.begin(), blobs.end(), [&](const Blob& b) { return b.partial == partial; });
    if (it == blobs.end()) {
      Blob blob;
      blob.digest.set_hash(f.sha256);
      blob.digest.set_size_bytes(f.size_bytes);
      blob.partial = partial;
      it = blobs.insert(blobs.end(), std::move(blob));
    }
    it->links.push_back(staged / f.name);
  }
  size_t kept_open = 0;
  // The large blobs' flush starts as each is complete, while the rest
  // download (early_sync.h); SyncStagedFiles then finds little left.
  EarlySync early_sync;
  for (Blob& blob : blobs) {
    absl::StatusOr<BlobOutcome> got = absl::UnknownError("not fetched");
    std::vector<std::string> failures;
    for (const ResultSource& source : plan.sources) {
      for (int attempt = 0;; ++attempt) {
        if (absl::StatusOr<Pinned> theirs = PinInstalled(layout, key); theirs.ok()) {
          return use_theirs(std::move(*theirs));
        }
        got = FetchBlob(source.reader, blob.digest, blob.partial, blob.links, hooks, cancel);
        if (got.status().code() != absl::StatusCode::kAborted || attempt == kMaxRetries) break;
      }
      if (got.ok() || StopsInstall(got.status())) break;
      if (plan.sources.size() > 1) {
        SdkLog().warn("event=blob_source_failed key={} file={} blob={} source=\"{}\" reason=\"{}\"", key,
                      blob.links.front().filename().string(), blob.digest.hash(), source.name,
                      std::string(got.status().message()));
        failures.push_back(absl::StrCat(source.name, ": ", got.status().message()));
      }
    }
    if (!got.ok()) {
      // The farm alone: its error as it is (as before mirrors existed); a
      // cancellation or a full local disk too. Otherwise the message names
      // the file (mirror messages name only URLs) and every source's
      // failure; the last one's code and details (payloads) are kept.
      if (StopsInstall(got.status()) || (plan.sources.size() == 1 && !plan.sources.front().mirror)) {
        return got.status();
      }
      if (failures.empty()) failures.push_back(absl::StrCat(plan.sources.front().name, ": ", got.status().message()));
      absl::Status named(got.status().code(),
                          absl::StrCat("file ", blob.links.front().filename().string(), " (blob ", blob.digest.hash(),
                                       ", ", blob.digest.size_bytes(), " bytes) of ", key,
                                       ": no source gave it intact: ", absl::StrJoin(failures, "; ")));
      got.status().ForEachPayload([&](absl::string_view type, const absl::Cord& payload) {
        named.SetPayload(type, payload);
      });
      return named;
    }
    outcome.bytes_downloaded += got->bytes_downloaded;
    outcome.bytes_resumed += got->bytes_resumed;
    early_sync.Add(got->file.get(), blob.digest.size_bytes(), blob.links.front());
    if (kept_open < kMaxFilesKeptOpen && got->file.valid()) {
      blob.fd = got->file.get();
      ++kept_open;
    } else {
      got->file.Reset();
    }
    if (got->shared) {
      used.push_back({blob.partial, got->identity, std::move(got->file)});
    } else {
      blob.own_file = std::move(got->file);
    }
  }

  if (absl::Status s = early_sync.Finish(); !s.ok()) return s;
  std::vector<StagedFile> staged_files;
  for (const Blob& blob : blobs) staged_files.push_back({blob.links.front(), blob.fd});
  if (absl::Status s = SyncStagedFiles(staged_files); !s.ok()) return s;
  if (absl::Status s = RecordFileIdentities(staged, outcome.record); !s.ok()) return s;
  if (absl::Status s = WriteSynced(staged / kEntryRecordName, EntryRecordToJson(outcome.record)); !s.ok()) return s;
  // Pinned before it is visible: an evictor in another process finds it in
  // use from the first moment.
  absl::StatusOr<std::unique_ptr<EntryLock>> pin = EntryLock::Shared(staged);
  if (!pin.ok()) return absl::InternalError(absl::StrCat("cannot install ", key, ": ", pin.status().message()));
  if (absl::Status s = SyncDir(staged); !s.ok()) return s;

  const fs::path entry = layout.EntryDir(key);
  for (int attempt = 0;; ++attempt) {
    if (::rename(staged.c_str(), entry.c_str()) == 0) break;
    const int err = errno;
    if (err != EEXIST && err != ENOTEMPTY) return LocalIoError(absl::StrCat("cannot install ", key, " as"), entry, err);
    // Someone (another process) installed it first; theirs is as good.
    absl::StatusOr<Pinned> theirs = PinInstalled(layout, key);
    if (theirs.ok()) return use_theirs(std::move(*theirs));
    if (theirs.status().code() != absl::StatusCode::kNotFound) return theirs.status();
    if (attempt == kMaxRetries) {
      return absl::InternalError(absl::StrCat("cannot install ", key, ": ", entry.string(),
                                              " exists but holds no readable entry"));
    }
    // Evicted between its install and our look: ours goes in instead.
  }
  (*staging)->Release();
  outcome.pin = std::move(*pin);
  if (hooks.on_installed) hooks.on_installed(key);
  if (absl::Status s = SyncDir(layout.EntriesDir()); !s.ok()) return s;
  // The partials' bytes live on in the entry (hard links); their names are
  // not needed any more, unless another download is using them now (it then
  // deletes them when done).
  RemoveUsedPartials(used);
  SdkLog().debug("cache: installed {} ({} bytes downloaded, {} resumed)", key, outcome.bytes_downloaded,
                 outcome.bytes_resumed);
  return outcome;
}

}  // namespace

absl::StatusOr<InstallOutcome> DownloadAndInstall(Transport& transport, const CacheLayout& layout,
                                                  const std::string& key, const DownloadHooks& hooks,
                                                  const CancelSource* cancel) {
  absl::StatusOr<v1::Manifest> listing = FarmListing(transport, key, cancel);
  if (!listing.ok()) return listing.status();
  InstallPlan plan;
  plan.listing = std::move(*listing);
  plan.listing_source = absl::StrCat("server ", transport.server());
  // Small blobs come many to a call, except those a partial file already
  // holds (an earlier install cut short resumes them from disk).
  auto not_partial = [&layout](const v1::Digest& d) {
    std::error_code ec;
    return !fs::exists(layout.PartialPath(d.hash(), d.size_bytes()), ec);
  };
  if (!UsesFarmHttp(transport)) {
    plan.sources.push_back({plan.listing_source, PrefetchingFarmReader(transport, plan.listing, not_partial, cancel),
                            /*mirror=*/false});
    return InstallFromSources(plan, layout, key, hooks, cancel);
  }
  // The farm's HTTP front end streams the rest (farm_http_fetch.h), and
  // ReadBlob is the source of last resort for a blob it cannot give
  // intact, resuming from the verified bytes on disk.
  BlobReader over_http = ReaderByFileName(
      plan.listing, [&transport, key](const std::string& file_name, const v1::Digest& digest, int64_t offset,
                                      Sha256& hash, const std::function<absl::Status(std::string_view)>& sink,
                                      const CancelSource* c) {
        return ReadResultFileOverHttp(transport, key, file_name, digest, offset, hash, sink, c);
      });
  plan.sources.push_back({absl::StrCat("farm HTTP ", transport.farm_http()),
                          PrefetchingFarmReader(transport, plan.listing, not_partial, cancel, std::move(over_http)),
                          /*mirror=*/false});
  plan.sources.push_back({plan.listing_source, FarmBlobReader(transport), /*mirror=*/false});
  return InstallFromSources(plan, layout, key, hooks, cancel);
}

InstallPlan FarmHttpInstallPlan(const FarmHttpEndpoint& front_end, v1::Manifest listing, BlobReader farm,
                                std::string farm_name) {
  InstallPlan plan;
  plan.listing = std::move(listing);
  plan.listing_source = absl::StrCat("farm HTTP ", front_end.base);
  BlobReader over_http = ReaderByFileName(
      plan.listing, [front_end, key = plan.listing.cache_key()](
                        const std::string& file_name, const v1::Digest& digest, int64_t offset, Sha256& hash,
                        const std::function<absl::Status(std::string_view)>& sink, const CancelSource* c) {
        HttpReadOptions read = front_end.read;
        read.cancel = c;
        return ReadFrontEndFile(front_end.base, read, key, file_name, digest, offset, hash, sink);
      });
  plan.sources.push_back({plan.listing_source, std::move(over_http), /*mirror=*/false});
  plan.sources.push_back({std::move(farm_name), std::move(farm), /*mirror=*/false});
  return plan;
}

std::optional<absl::StatusOr<InstallOutcome>> InstallOverFarmHttp(const FarmHttpEndpoint& front_end, BlobReader farm,
                                                                  std::string farm_name, const CacheLayout& layout,
                                                                  const std::string& key, const DownloadHooks& hooks,
                                                                  const CancelSource* cancel) {
  FarmHttpEndpoint asking = front_end;
  asking.read.cancel = cancel;
  absl::StatusOr<v1::Manifest> listing = GetResultOverHttp(asking, key);
  if (listing.ok()) {
    return InstallFromSources(FarmHttpInstallPlan(front_end, std::move(*listing), std::move(farm), std::move(farm_name)),
                              layout, key, hooks, cancel);
  }
  if (absl::IsCancelled(listing.status())) return listing.status();
  if (absl::IsNotFound(listing.status())) {
    SdkLog().debug("event=farm_http_listing_not_found key={} reason=\"{}\"", key,
                   std::string(listing.status().message()));
  } else {
    SdkLog().warn("event=farm_http_listing_failed key={} reason=\"{}\" note=\"asking the farm over gRPC\"", key,
                  std::string(listing.status().message()));
  }
  return std::nullopt;
}

absl::StatusOr<InstallOutcome> InstallFromSources(const InstallPlan& plan, const CacheLayout& layout,
                                                  const std::string& key, const DownloadHooks& hooks,
                                                  const CancelSource* cancel) {
  std::vector<UsedPartial> used;
  absl::StatusOr<InstallOutcome> outcome = Install(plan, layout, key, hooks, cancel, used);
  if (!outcome.ok() && IsLocalDiskFull(outcome.status())) {
    // Complete partial files would hold the very space that is missing,
    // and a result is useless without all its files: nothing stays behind
    // (but what another download is using right now).
    RemoveUsedPartials(used);
  }
  return outcome;
}

bool RemoveStagingIfUnused(const fs::path& dir, double min_age_seconds) {
  struct stat st;
  if (::lstat(dir.c_str(), &st) != 0) return false;
  // Young ones are left alone: one may not be locked yet by the install
  // creating it.
  if (AgeSeconds(st) < min_age_seconds) return false;
  if (!S_ISDIR(st.st_mode)) {
    std::error_code ec;
    return fs::remove(dir, ec);  // a stray file
  }
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC | O_NOFOLLOW);
  if (fd < 0) return false;
  bool removed = false;
  if (::flock(fd, LOCK_EX | LOCK_NB) == 0) {
    std::error_code ec;
    removed = fs::remove_all(dir, ec) > 0;
  }
  ::close(fd);
  return removed;
}

}  // namespace impostor::sdk
