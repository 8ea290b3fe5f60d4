// Reads one content-addressed file over HTTP(S) (a release mirror's blob or
// catalog, or a result file from the farm's own HTTP front end), verifying
// it against its digest as it streams: the transfer behind the SDK's mirror
// downloads and its fetches of farm results over HTTP. A cut transfer is resumed on the same mirror with
// a Range request while bytes keep arriving; anything that proves the mirror
// wrong (a byte too many, an error page, a body that hashes wrong) is
// DATA_LOSS, which makes the caller move on to its next source. Runs on the
// caller's thread.
#ifndef IMPOSTOR_CLIENT_TRANSFER_HTTP_BLOB_READ_H_
#define IMPOSTOR_CLIENT_TRANSFER_HTTP_BLOB_READ_H_

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

#include "absl/strings/string_view.h"
#include "absl/status/status.h"
#include "client/transport/retry.h"
#include "common/util/sha256.h"

namespace impostor::sdk {

struct HttpReadOptions {
  // No byte for this long: the link stalled (DEADLINE_EXCEEDED).
  double stall_seconds = 30;
  // Transfers in a row that bring no byte before giving up on this mirror.
  int max_attempts = 3;
  const sdk::CancelSource* cancel = nullptr;  // may be null
  std::string ca_file;                        // HTTPS trust; empty = system
  // Sent as the Authorization header when not empty ("Bearer <token>": the
  // farm's own front end; mirrors need none).
  std::string authorization;
};

// Feeds bytes [offset, size_bytes) of the file at `url` to `sink` and
// `hash` (which has seen bytes [0, offset)), then checks that everything
// hashed equals `sha256`. Errors: NOT_FOUND (404), UNAVAILABLE (cannot
// connect; an HTTP error status; a transfer cut max_attempts times without
// progress), DEADLINE_EXCEEDED (stalled), DATA_LOSS (more bytes than
// size_bytes, a Content-Range at another offset, a wrong digest: the sink
// has then seen bad bytes and the caller must discard them), CANCELLED, or
// the sink's error. Messages name the URL and the digest.
absl::Status ReadVerified(const std::string& url, absl::string_view sha256, int64_t size_bytes, int64_t offset,
                          Sha256& hash, const std::function<absl::Status(std::string_view)>& sink,
                          const HttpReadOptions& options);

// ReadVerified of a small file into memory.
absl::StatusOr<std::string> ReadVerifiedToString(const std::string& url, absl::string_view sha256,
                                                 int64_t size_bytes, const HttpReadOptions& options);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSFER_HTTP_BLOB_READ_H_
