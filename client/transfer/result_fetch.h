// Installs a baked result into a directory: the map images, then
// manifest.json, each verified and renamed into place; files already there
// with the right digest are kept. Runs on the caller's thread and, with
// parallel > 1, on threads of its own for the downloads.
#ifndef IMPOSTOR_CLIENT_TRANSFER_RESULT_FETCH_H_
#define IMPOSTOR_CLIENT_TRANSFER_RESULT_FETCH_H_

#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "client/base/atomic_file.h"
#include "client/transfer/parallel_downloads.h"
#include "client/transport/transport.h"
#include "impostor/client.h"
#include "impostor/v1/types.pb.h"

namespace impostor::sdk {

inline constexpr char kManifestFileName[] = "manifest.json";

// Errors: those of GetResult, INTERNAL for a malformed manifest or local
// disk trouble, DATA_LOSS naming the file whose bytes do not verify, or a
// ReadBlob's error. On any error no file of the result has been renamed
// into out_dir. `parallel`: downloads in flight at once (>= 1).
absl::StatusOr<FetchResult> FetchResultFiles(Transport& transport, const std::string& cache_key,
                                             const std::filesystem::path& out_dir,
                                             int parallel = DefaultParallelDownloads());

// How InstallResultFiles gets a result's files.
struct ResultFileRoads {
  // One file into a temporary file beside `path` holding only its verified
  // bytes (blob_download.h's DownloadBlobToStagedFile). Required.
  std::function<absl::StatusOr<std::unique_ptr<AtomicFileWriter>>(
      const std::string& file_name, const v1::Digest& digest, const std::filesystem::path& path,
      const CancelSource& cancel)>
      stream;
  // Many small files in one call, as ReadBlobBatch (blob_batch.h) for one
  // batch of PackBlobBatches; UNIMPLEMENTED streams that batch's files one
  // each. Empty: every file is streamed.
  std::function<absl::Status(const std::vector<v1::Digest>& digests,
                             const std::function<absl::Status(size_t i, std::string_view bytes)>& on_blob,
                             size_t* failed, const CancelSource& cancel)>
      batch;
};

// The install half of FetchResultFiles, for a manifest that passed
// CheckManifestFiles, whichever road the bytes take: the same errors but
// GetResult's, the same guarantee (nothing renamed into out_dir on error).
absl::StatusOr<FetchResult> InstallResultFiles(const v1::Manifest& manifest, const std::filesystem::path& out_dir,
                                               int parallel, const ResultFileRoads& roads);

// INVALID_ARGUMENT unless every map names a distinct plain file name (no
// directory part, not manifest.json) with a well-formed digest, and the
// manifest_json digest is well-formed: a result comes from the network and
// must not write outside out_dir.
absl::Status CheckManifestFiles(const v1::Manifest& manifest);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSFER_RESULT_FETCH_H_
