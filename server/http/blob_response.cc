#include "server/http/blob_response.h"

#include <spdlog/spdlog.h>

#include <string_view>

#include "absl/strings/str_cat.h"
#include "common/util/log_escape.h"
#include "server/http/byte_range.h"

namespace impostor {
namespace {

// Writes `span` of the blob to `sink`. False, which makes the library close
// the connection, when the read failed or the client went away.
bool StreamSpan(const BlobStore& blobs, const BlobDigest& digest, ByteSpan span, const std::string& path,
                httplib::DataSink& sink) {
  // BlobStore::Read checks a whole blob's hash only after it has passed on
  // the final chunk; holding each chunk back until the next one is read
  // keeps that chunk from the client until the hash is known to match.
  std::string held;
  int64_t sent = 0;
  bool client_gone = false;
  const absl::Status read =
      blobs.Read(digest, span.offset, span.length, kBlobChunkBytes, [&](std::string_view chunk, int64_t) {
        if (!held.empty()) {
          if (!sink.write(held.data(), held.size())) {
            client_gone = true;
            return false;
          }
          sent += static_cast<int64_t>(held.size());
        }
        held.assign(chunk);
        return true;
      });
  if (client_gone) {
    spdlog::debug("event=http_blob_client_gone blob={} path=\"{}\" sent_bytes={}", digest.ToString(),
                  EscapeUntrusted(path, 200), sent);
    return false;
  }
  if (!read.ok()) {
    spdlog::warn("event=http_blob_cut blob={} path=\"{}\" sent_bytes={} of_bytes={} reason=\"{}\"",
                 digest.ToString(), EscapeUntrusted(path, 200), sent, span.length,
                 EscapeUntrusted(std::string(read.message()), 300));
    return false;
  }
  if (!held.empty() && !sink.write(held.data(), held.size())) return false;
  sink.done();
  return true;
}

}  // namespace

absl::Status ServeBlob(const BlobStore& blobs, const BlobDigest& digest, const std::string& content_type,
                       const httplib::Request& req, httplib::Response& res) {
  if (auto s = blobs.Verify(digest); !s.ok()) return s;
  ByteSpan span{.offset = 0, .length = digest.size_bytes};
  int status = 200;
  if (req.ranges.size() == 1) {
    const auto asked = ResolveByteRange(req.ranges[0].first, req.ranges[0].second, digest.size_bytes);
    if (!asked) {
      res.status = 416;
      res.set_header("Content-Range", absl::StrCat("bytes */", digest.size_bytes));
      return absl::OkStatus();
    }
    span = *asked;
    status = 206;
    res.set_header("Content-Range", ContentRangeOf(span, digest.size_bytes));
  } else if (req.ranges.size() > 1) {
    // Answered whole. cpp-httplib would still relabel the response
    // multipart/byteranges after this handler (and its multipart writer
    // reads a provider's ranges against an empty body), so the ranges are
    // dropped from the request: the library's own Request, not const there.
    const_cast<httplib::Request&>(req).ranges.clear();
  }
  res.status = status;
  res.set_header("Accept-Ranges", "bytes");
  res.set_header("Content-Length", std::to_string(span.length));
  // The provider without a length: given one, cpp-httplib would apply the
  // Range header itself, unclamped; without, it writes what the provider
  // writes, under the headers set here.
  res.set_content_provider(content_type, [&blobs, digest, span, path = req.path](size_t, httplib::DataSink& sink) {
    return StreamSpan(blobs, digest, span, path, sink);
  });
  return absl::OkStatus();
}

}  // namespace impostor
