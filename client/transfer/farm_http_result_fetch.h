// A farm result fetched over the farm's HTTP front end alone: its listing
// (BASE/api/v1/results/KEY/manifest, the impostor.v1.Manifest gRPC's
// GetResult answers) and every file (BASE/api/v1/results/KEY/files/NAME),
// each verified as it streams, installed as FetchResultFiles installs. No
// gRPC channel is opened: a fetch then costs what an HTTP client's does
// (issue 45), and reaches a farm through anything that carries HTTPS.
// FetchFromFarm (impostor/client.h) falls back to gRPC when this fails.
#ifndef IMPOSTOR_CLIENT_TRANSFER_FARM_HTTP_RESULT_FETCH_H_
#define IMPOSTOR_CLIENT_TRANSFER_FARM_HTTP_RESULT_FETCH_H_

#include <filesystem>
#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "client/transfer/http_blob_read.h"
#include "impostor/client.h"
#include "impostor/v1/types.pb.h"

namespace impostor::sdk {

// A farm's HTTP front end as one fetch reads it.
struct FarmHttpEndpoint {
  std::string base;     // http(s)://host[:port][/prefix], no trailing "/"
  HttpReadOptions read;  // token, CA, stall; max_attempts 1 (gRPC is the next road)
};

// The front end `options` name (farm_http, else $IMPOSTOR_FARM_HTTP), read
// with their token (token_file, token, $IMPOSTOR_TOKEN), CA file and
// rpc_timeout_seconds as the stall limit; nullopt when none is named or
// "none" turns it off (one the farm advertises needs gRPC to learn).
// INVALID_ARGUMENT as Transport::Connect for bad options.
absl::StatusOr<std::optional<FarmHttpEndpoint>> ConfiguredFarmHttp(const ClientOptions& options);

// The result's listing. Errors: INVALID_ARGUMENT for a key that is not 64
// lowercase hex characters (it goes into the URL); NOT_FOUND (HTTP 404: no
// such result, or a front end older than the listing), UNAVAILABLE (cannot
// connect, another HTTP status: 401 for a refused token),
// DEADLINE_EXCEEDED, and DATA_LOSS for an answer that is not this result's
// listing (another media type, over kMaxResultManifestBytes, not a
// Manifest, another cache key, files CheckManifestFiles refuses). Messages
// name the URL and the server's own message when it sent one.
absl::StatusOr<v1::Manifest> GetResultOverHttp(const FarmHttpEndpoint& front_end, const std::string& cache_key);

// FetchResultFiles over HTTP alone: the listing, then every file from the
// front end (`parallel` at once, each on its own kept-alive connection),
// verified, synced once and renamed in. Errors: GetResultOverHttp's, and
// ReadVerified's for a file (NOT_FOUND, UNAVAILABLE, DEADLINE_EXCEEDED,
// DATA_LOSS naming the URL and the digest), or INTERNAL for local disk
// trouble; on any error nothing of the result was renamed into out_dir.
absl::StatusOr<FetchResult> FetchResultFilesOverHttp(const FarmHttpEndpoint& front_end, const std::string& cache_key,
                                                     const std::filesystem::path& out_dir, int parallel);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSFER_FARM_HTTP_RESULT_FETCH_H_
