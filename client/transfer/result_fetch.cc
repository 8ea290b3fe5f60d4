#include "client/transfer/result_fetch.h"

#include <algorithm>
#include <chrono>
#include <mutex>
#include <set>
#include <system_error>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/base/early_sync.h"
#include "client/transfer/blob_batch.h"
#include "client/transfer/blob_download.h"
#include "client/transfer/farm_http_fetch.h"
#include "client/transfer/parallel_downloads.h"
#include "common/request/bake_request.h"
#include "common/util/sha256.h"

namespace impostor::sdk {
namespace {

namespace fs = std::filesystem;

struct Wanted {
  fs::path path;
  v1::Digest digest;
};

// True when `path` already holds exactly the blob `digest`.
bool AlreadyThere(const fs::path& path, const v1::Digest& digest) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return false;
  const uintmax_t size = fs::file_size(path, ec);
  if (ec || static_cast<int64_t>(size) != digest.size_bytes()) return false;  // cheap check first
  absl::StatusOr<BlobDigest> actual = DigestFile(path);
  return actual.ok() && actual->hash == digest.hash();
}

}  // namespace

absl::Status CheckManifestFiles(const v1::Manifest& manifest) {
  if (absl::Status s = ValidateDigest("manifest_json", manifest.manifest_json().hash(),
                                      manifest.manifest_json().size_bytes());
      !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("result manifest: ", s.message()));
  }
  std::set<std::string> names = {kManifestFileName};
  for (int i = 0; i < manifest.maps_size(); ++i) {
    const v1::MapFile& map = manifest.maps(i);
    const std::string field = absl::StrCat("result manifest: maps[", i, "]");
    if (absl::Status s = ValidateRelativePath(field + ".file", map.file()); !s.ok()) return s;
    if (map.file().find('/') != std::string::npos || !names.insert(map.file()).second) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ".file: \"", map.file(), "\" is not a distinct plain file name"));
    }
    if (absl::Status s = ValidateDigest(field + ".digest", map.digest().hash(), map.digest().size_bytes());
        !s.ok()) {
      return s;
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<FetchResult> FetchResultFiles(Transport& transport, const std::string& cache_key,
                                             const fs::path& out_dir, int parallel) {
  const auto start = std::chrono::steady_clock::now();
  absl::StatusOr<v1::Manifest> manifest = transport.GetResult(cache_key);
  if (!manifest.ok()) return manifest.status();
  if (absl::Status s = CheckManifestFiles(*manifest); !s.ok()) {
    return absl::InternalError(absl::StrCat("server ", transport.server(), " sent a bad result for ", cache_key,
                                            ": ", s.message()));
  }
  // Large files stream from the farm's HTTP front end when there is one
  // (farm_http_fetch.h), else over ReadBlob. Small files go many to a call
  // (BatchReadBlobs: blob_batch.h): one round trip for a result's 36 view
  // images and its manifest instead of one each.
  ResultFileRoads roads;
  roads.stream = [&](const std::string& file_name, const v1::Digest& digest, const fs::path& path,
                     const CancelSource& cancel) {
    return DownloadResultFileToStagedFile(transport, cache_key, file_name, digest, path, &cancel);
  };
  roads.batch = [&](const std::vector<v1::Digest>& digests,
                    const std::function<absl::Status(size_t, std::string_view)>& on_blob, size_t* failed,
                    const CancelSource& cancel) { return ReadBlobBatch(transport, digests, on_blob, failed, &cancel); };
  absl::StatusOr<FetchResult> result = InstallResultFiles(*manifest, out_dir, parallel, roads);
  if (result.ok()) result->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

absl::StatusOr<FetchResult> InstallResultFiles(const v1::Manifest& manifest, const fs::path& out_dir, int parallel,
                                               const ResultFileRoads& roads) {
  const auto start = std::chrono::steady_clock::now();
  const std::string& cache_key = manifest.cache_key();
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec || !fs::is_directory(out_dir)) {
    return absl::InternalError(absl::StrCat("cannot create directory ", out_dir.string(), ": ",
                                            ec ? ec.message() : std::string("not a directory")));
  }

  // Maps first, manifest.json last: a manifest on disk means its maps are.
  std::vector<Wanted> wanted;
  for (const v1::MapFile& map : manifest.maps()) wanted.push_back({out_dir / map.file(), map.digest()});
  wanted.push_back({out_dir / kManifestFileName, manifest.manifest_json()});

  FetchResult result;
  result.dir = out_dir;
  result.manifest_path = out_dir / kManifestFileName;
  result.warnings.assign(manifest.warnings().begin(), manifest.warnings().end());
  // A manifest.json from another result goes first: replacing maps beside
  // it would leave a manifest that does not describe them if this fetch
  // then fails half-way (a CI job re-fetching into the same folder).
  if (!AlreadyThere(result.manifest_path, manifest.manifest_json())) {
    fs::remove(result.manifest_path, ec);
    if (ec) {
      return absl::InternalError(absl::StrCat("cannot remove the previous ", result.manifest_path.string(),
                                              " before fetching ", cache_key, ": ", ec.message()));
    }
  }
  // The files are downloaded side by side (RunParallelDownloads), each
  // into a temporary file beside its name with its writeback started; once
  // all are there and verified they are synced together and renamed in
  // order (maps, then manifest.json): one wait for the disk per result, and
  // nothing renamed in when any file failed.
  std::vector<bool> reused(wanted.size(), false);
  std::vector<size_t> order;  // the files to download, largest first
  for (size_t i = 0; i < wanted.size(); ++i) {
    reused[i] = AlreadyThere(wanted[i].path, wanted[i].digest);
    if (!reused[i]) order.push_back(i);
  }
  // Largest first: the long streams start at once and the small files
  // fill the gaps beside them, rather than one large file running alone
  // at the end (smallest first measured the same within noise on two
  // cores, 0.52 against 0.51 s with 4 streams; one stream does not care).
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return wanted[a].digest.size_bytes() > wanted[b].digest.size_bytes();
  });
  // Small files go many to a call when the roads have one (roads.batch),
  // after the large ones' streams. A server that predates the call answers
  // UNIMPLEMENTED; the files of such batches are then streamed one each,
  // side by side, as before.
  std::vector<size_t> streamed;
  std::vector<v1::Digest> small;
  std::vector<size_t> small_files;  // index into wanted of each of small
  for (size_t i : order) {
    if (roads.batch && FitsBlobBatch(wanted[i].digest)) {
      small.push_back(wanted[i].digest);
      small_files.push_back(i);
    } else {
      streamed.push_back(i);
    }
  }
  const std::vector<std::vector<size_t>> batches = PackBlobBatches(small);
  std::mutex unbatched_mu;
  std::vector<size_t> unbatched;  // files of batches the server could not answer
  // The large files' flush starts as each is complete, while the rest
  // download (early_sync.h); CommitAll then finds little left to wait for.
  EarlySync early_sync;
  std::vector<std::unique_ptr<AtomicFileWriter>> downloaded(wanted.size());
  auto stream_file = [&](size_t i, const CancelSource& cancel) {
    absl::StatusOr<std::unique_ptr<AtomicFileWriter>> staged =
        roads.stream(wanted[i].path.filename().string(), wanted[i].digest, wanted[i].path, cancel);
    if (!staged.ok()) return staged.status();
    early_sync.Add((*staged)->fd(), wanted[i].digest.size_bytes(), wanted[i].path);
    downloaded[i] = std::move(*staged);
    return absl::OkStatus();
  };
  auto batch_files = [&](const std::vector<size_t>& batch, const CancelSource& cancel) {
    std::vector<v1::Digest> digests;
    for (size_t k : batch) digests.push_back(small[k]);
    size_t failed = batch.size();  // set to the blob a blob's own error names
    const absl::Status read = roads.batch(
        digests,
        [&](size_t k, std::string_view bytes) -> absl::Status {
          const Wanted& file = wanted[small_files[batch[k]]];
          absl::StatusOr<std::unique_ptr<AtomicFileWriter>> writer = AtomicFileWriter::Create(file.path);
          if (!writer.ok()) return writer.status();
          if (absl::Status s = (*writer)->Append(bytes); !s.ok()) return s;
          (*writer)->StartWriteback();
          downloaded[small_files[batch[k]]] = std::move(*writer);
          return absl::OkStatus();
        },
        &failed, cancel);
    if (absl::IsUnimplemented(read)) {
      std::lock_guard lock(unbatched_mu);
      for (size_t k : batch) unbatched.push_back(small_files[k]);
      return absl::OkStatus();
    }
    // A blob's own error names its file, as a streamed download's
    // verification failure does; the call's error stays as it came.
    if (read.ok() || failed >= batch.size()) return read;
    return absl::Status(read.code(),
                        absl::StrCat(wanted[small_files[batch[failed]]].path.string(), ": ", read.message()));
  };
  absl::Status status = RunParallelDownloads(
      streamed.size() + batches.size(), parallel, nullptr, [&](size_t n, const CancelSource& cancel) {
        return n < streamed.size() ? stream_file(streamed[n], cancel)
                                   : batch_files(batches[n - streamed.size()], cancel);
      });
  if (status.ok() && !unbatched.empty()) {
    std::sort(unbatched.begin(), unbatched.end(), [&](size_t a, size_t b) {
      return wanted[a].digest.size_bytes() > wanted[b].digest.size_bytes();
    });
    status = RunParallelDownloads(unbatched.size(), parallel, nullptr,
                                  [&](size_t n, const CancelSource& cancel) { return stream_file(unbatched[n], cancel); });
  }
  if (!status.ok()) return status;
  if (absl::Status s = early_sync.Finish(); !s.ok()) return s;
  std::vector<std::unique_ptr<AtomicFileWriter>> staged;
  for (std::unique_ptr<AtomicFileWriter>& file : downloaded) {
    if (file != nullptr) staged.push_back(std::move(file));
  }
  if (absl::Status s = CommitAll(staged); !s.ok()) return s;
  for (size_t i = 0; i < wanted.size(); ++i) {
    (reused[i] ? result.bytes_reused : result.bytes_downloaded) += wanted[i].digest.size_bytes();
    result.files.push_back(wanted[i].path);
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace impostor::sdk
