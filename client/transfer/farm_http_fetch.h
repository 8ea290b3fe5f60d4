// A farm result's files over the farm's HTTP front end
// (ClientOptions::farm_http), with gRPC as the fallback: the road for a
// result's large files when one is configured (issue 45). gRPC relays a
// large blob in 64 KiB messages, each one a receive, a window update and a
// few context switches (docs/explanation/figures.md measured ~300 MB/s on
// two cores); the front end serves the same bytes as plain HTTP responses
// at nginx's pace. The listing (GetResult) and the small files (one
// BatchReadBlobs call) stay on gRPC here; farm_http_result_fetch.h takes
// them over HTTP too, without a transport. Runs on the caller's thread.
#ifndef IMPOSTOR_CLIENT_TRANSFER_FARM_HTTP_FETCH_H_
#define IMPOSTOR_CLIENT_TRANSFER_FARM_HTTP_FETCH_H_

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "client/base/atomic_file.h"
#include "client/transfer/http_blob_read.h"
#include "client/transport/retry.h"
#include "client/transport/transport.h"
#include "common/util/sha256.h"
#include "impostor/v1/types.pb.h"

namespace impostor::sdk {

// How the front end is read: a stall is rpc_timeout_seconds without a byte;
// a transfer that brings nothing gives the file up at once (gRPC is one step
// away), one cut after bringing bytes is resumed; https:// trusts
// tls_ca_file when set, and the request carries the transport's token.
HttpReadOptions FarmHttpReadOptions(const Transport& transport, const CancelSource* cancel);

// Files in a row the front end could not give (any failure but a
// cancellation or the sink's own) after which the transport stops asking it:
// a misconfigured URL or token then costs three warnings, not two for each
// result of a 5,000-asset batch. A file it gives resets the count.
inline constexpr int kFarmHttpFailuresToGiveUp = 3;

// True while the transport has a front end it has not given up on.
bool UsesFarmHttp(const Transport& transport);

// Feeds bytes [offset, size) of file `file_name` of result `cache_key` from
// the front end to `sink` and `hash` (which has seen bytes [0, offset)),
// then checks the whole file's SHA-256 against `digest`. `sink` gets the
// bytes in pieces of at least 256 KiB (but the last), and on return has seen
// every byte `hash` has, whatever the outcome. Errors as
// ReadVerified (transfer/http_blob_read.h): NOT_FOUND, UNAVAILABLE (an HTTP
// error status too: 401 for a token the front end refuses),
// DEADLINE_EXCEEDED, DATA_LOSS (the sink has then seen bad bytes), or the
// sink's. FAILED_PRECONDITION when the transport has no front end or gave
// it up (kFarmHttpFailuresToGiveUp; one warning line says so).
absl::Status ReadResultFileOverHttp(const Transport& transport, const std::string& cache_key,
                                    const std::string& file_name, const v1::Digest& digest, int64_t offset,
                                    Sha256& hash, const std::function<absl::Status(std::string_view)>& sink,
                                    const CancelSource* cancel);

// ReadResultFileOverHttp from front end `base` (no trailing "/") read with
// `read`, without a transport's bookkeeping: the same errors but
// FAILED_PRECONDITION. For a fetch over HTTP alone (farm_http_result_fetch.h).
absl::Status ReadFrontEndFile(const std::string& base, const HttpReadOptions& read, const std::string& cache_key,
                             const std::string& file_name, const v1::Digest& digest, int64_t offset, Sha256& hash,
                             const std::function<absl::Status(std::string_view)>& sink);

// The whole of a result's file from front end `base` into a temporary file
// beside `path` (AtomicFileWriter, its writeback started), verified; on
// error nothing is left and `*local_error` says whether the local file
// failed (no other road helps then) rather than the front end.
absl::StatusOr<std::unique_ptr<AtomicFileWriter>> DownloadFrontEndFileToStagedFile(
    const std::string& base, const HttpReadOptions& read, const std::string& cache_key, const std::string& file_name,
    const v1::Digest& digest, const std::filesystem::path& path, bool* local_error);

// DownloadBlobToStagedFile (blob_download.h) of a result's file: from the
// front end when the transport has one, and over gRPC when it has none or
// when the front end cannot give the file intact (any error but a
// cancellation or the local file's own), after one warning line naming the
// file and why. The temporary file holds only verified bytes either way.
absl::StatusOr<std::unique_ptr<AtomicFileWriter>> DownloadResultFileToStagedFile(
    Transport& transport, const std::string& cache_key, const std::string& file_name, const v1::Digest& digest,
    const std::filesystem::path& path, const CancelSource* cancel = nullptr);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSFER_FARM_HTTP_FETCH_H_
