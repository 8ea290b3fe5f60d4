// Installs a baked result into a directory: the map images, then
// manifest.json, each verified and renamed into place; files already there
// with the right digest are kept. Runs on the caller's thread.
#ifndef IMPOSTOR_CLIENT_TRANSFER_RESULT_FETCH_H_
#define IMPOSTOR_CLIENT_TRANSFER_RESULT_FETCH_H_

#include <filesystem>
#include <string>

#include "absl/status/statusor.h"
#include "client/transport/transport.h"
#include "impostor/client.h"
#include "impostor/v1/types.pb.h"

namespace impostor::sdk {

inline constexpr char kManifestFileName[] = "manifest.json";

absl::StatusOr<FetchResult> FetchResultFiles(Transport& transport, const std::string& cache_key,
                                             const std::filesystem::path& out_dir);

// INVALID_ARGUMENT unless every map names a distinct plain file name (no
// directory part, not manifest.json) with a well-formed digest, and the
// manifest_json digest is well-formed: a result comes from the network and
// must not write outside out_dir.
absl::Status CheckManifestFiles(const v1::Manifest& manifest);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSFER_RESULT_FETCH_H_
