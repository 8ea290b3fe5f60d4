// One HTTP(S) GET through libcurl, streaming the body to a callback: what
// the SDK uses to read release trees from mirrors (CDN edges, static hosts,
// the farm's own /releases/) and result files from the farm's HTTP front
// end. Connections are kept alive per thread (one
// curl handle per calling thread), so many small files over one mirror do
// not pay a handshake each.
//
// Thread-safety: any thread may call HttpGet; each call uses its thread's
// handle.
#ifndef IMPOSTOR_CLIENT_TRANSPORT_HTTP_GET_H_
#define IMPOSTOR_CLIENT_TRANSPORT_HTTP_GET_H_

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "client/transport/retry.h"

namespace impostor::sdk {

struct HttpGetOptions {
  // Fail when no byte arrives for this long (the link stalled):
  // DEADLINE_EXCEEDED. Also the connect timeout.
  double stall_seconds = 30;
  // Ask for bytes from this offset on (Range: bytes=N-); 0 = the whole body.
  int64_t offset = 0;
  // If-None-Match; a 304 answer then has status 304 and no body.
  std::string if_none_match;
  // Bytes of body accepted at most; more is DATA_LOSS at once (a mirror that
  // answers a blob with something larger than its digest says).
  int64_t max_body_bytes = INT64_MAX;
  // May be null; Cancel() ends the transfer at once with cancel->error().
  const sdk::CancelSource* cancel = nullptr;
  // CA bundle for HTTPS (empty = the system's).
  std::string ca_file;
  // Bytes libcurl reads from the socket at a time; 0 = its default (16
  // KiB). A large file wants more (256 KiB: a 15 MB map in ~60 reads, not
  // ~900); the body still reaches the sink in pieces of 16 KiB at most.
  long receive_buffer_bytes = 0;
  // The Authorization header's value ("Bearer <token>"), empty = none.
  // libcurl does not send it on to another host after a redirect.
  std::string authorization;
};

struct HttpGetResult {
  long status = 0;
  std::string etag;          // as sent, quotes included
  std::string content_type;
  // For 206: the first byte of the body within the whole file (from
  // Content-Range); 0 for a 200.
  int64_t range_start = 0;
  int64_t body_bytes = 0;    // delivered to the sink
  // The Repr-Digest header as sent (RFC 9530, e.g. "sha-256=:BASE64:"), ""
  // when absent.
  std::string repr_digest;
  // The first kErrorBodyBytes of the body of a response other than 200 or
  // 206 (the server's explanation), which the sink never sees.
  std::string error_body;
  static constexpr size_t kErrorBodyBytes = 4096;
};

// GETs `url`, feeding the body (of any status) to `sink`; a non-OK status
// from the sink ends the transfer and is returned as is. Errors: UNAVAILABLE
// (cannot connect, resolve, or the connection broke: the result so far is
// lost, `*partial_bytes` says how many body bytes the sink got),
// DEADLINE_EXCEEDED (stalled), DATA_LOSS (body beyond max_body_bytes),
// INVALID_ARGUMENT (a URL libcurl cannot use), CANCELLED. Any HTTP status
// is a successful call: the caller judges it.
absl::StatusOr<HttpGetResult> HttpGet(const std::string& url, const HttpGetOptions& options,
                                      const std::function<absl::Status(std::string_view)>& sink,
                                      int64_t* partial_bytes = nullptr);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSPORT_HTTP_GET_H_
