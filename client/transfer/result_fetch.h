// Installs a baked result into a directory: the map images, then
// manifest.json, each verified and renamed into place; files already there
// with the right digest are kept. Runs on the caller's thread and, with
// parallel > 1, on threads of its own for the downloads.
#ifndef IMPOSTOR_CLIENT_TRANSFER_RESULT_FETCH_H_
#define IMPOSTOR_CLIENT_TRANSFER_RESULT_FETCH_H_

#include <filesystem>
#include <string>

#include "absl/status/statusor.h"
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

// INVALID_ARGUMENT unless every map names a distinct plain file name (no
// directory part, not manifest.json) with a well-formed digest, and the
// manifest_json digest is well-formed: a result comes from the network and
// must not write outside out_dir.
absl::Status CheckManifestFiles(const v1::Manifest& manifest);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSFER_RESULT_FETCH_H_
