#include "server/http/release_response.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <memory>
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "common/util/log_escape.h"
#include "common/util/sha256.h"
#include "server/http/byte_range.h"
#include "server/http/json_api.h"

namespace impostor {
namespace {

// A channel file is a few hundred bytes; anything this large is not one.
constexpr int64_t kMaxChannelBytes = int64_t{1} << 20;
// Read and written at a time (as blob_response.h's chunks).
constexpr size_t kSendChunkBytes = size_t{64} << 10;

constexpr char kImmutableCacheControl[] = "public, max-age=31536000, immutable";
constexpr char kChannelCacheControl[] = "public, max-age=10";

std::string Quoted(std::string_view tag) { return "\"" + std::string(tag) + "\""; }

bool IsSpace(char c) { return c == ' ' || c == '\t'; }

void Refuse(httplib::Response& res, int status, const std::string& message) {
  res.status = status;
  res.set_header("Cache-Control", "no-store");
  res.set_content(ErrorJson(status, message), "application/json");
}

// Writes `span` of `file` to `sink`. False, which makes the library close
// the connection (the client sees fewer bytes than Content-Length said),
// when a read fails, the file ends early (cut since it was opened) or the
// client went away.
bool StreamFile(const OpenReleaseFile& file, ByteSpan span, const std::string& relative, httplib::DataSink& sink) {
  std::string chunk;
  int64_t sent = 0;
  while (sent < span.length) {
    const size_t want = static_cast<size_t>(std::min<int64_t>(kSendChunkBytes, span.length - sent));
    const absl::Status read = file.ReadAt(span.offset + sent, want, chunk);
    if (!read.ok() || chunk.empty()) {
      spdlog::warn("event=release_file_cut path=\"{}\" sent_bytes={} of_bytes={} reason=\"{}\"", relative, sent,
                   span.length, read.ok() ? "the file is shorter than when it was opened" : read.ToString());
      return false;
    }
    if (!sink.write(chunk.data(), chunk.size())) return false;
    sent += static_cast<int64_t>(chunk.size());
  }
  sink.done();
  return true;
}

}  // namespace

bool IfNoneMatchMatches(std::string_view header, std::string_view etag) {
  while (!header.empty()) {
    const size_t comma = header.find(',');
    std::string_view tag = header.substr(0, comma);
    header = comma == std::string_view::npos ? std::string_view() : header.substr(comma + 1);
    while (!tag.empty() && IsSpace(tag.front())) tag.remove_prefix(1);
    while (!tag.empty() && IsSpace(tag.back())) tag.remove_suffix(1);
    if (tag == "*") return true;
    if (tag.starts_with("W/")) tag.remove_prefix(2);
    if (!tag.empty() && tag == etag) return true;
  }
  return false;
}

void ServeReleaseFile(ReleaseTree& tree, const httplib::Request& const_req, httplib::Response& res) {
  // The ranges are taken here and cleared in the library's own Request (not
  // const there): given any, cpp-httplib would apply them itself after this
  // handler, cutting an error body, or relabelling a whole answer to
  // several ranges multipart/byteranges (blob_response.cc does the same).
  httplib::Request& req = const_cast<httplib::Request&>(const_req);
  const httplib::Ranges ranges = std::move(req.ranges);
  req.ranges.clear();

  // The target as sent: req.path is percent-decoded, and "%2e%2e" or "%2f"
  // must not become "..", "/" on their way to the parser.
  std::string_view target = req.target;
  target = target.substr(0, target.find('?'));
  std::optional<ReleasePath> path;
  if (target.starts_with(kReleasesUrlPrefix)) path = ParseReleasePath(target.substr(kReleasesUrlPrefix.size()));
  if (!path) {
    Refuse(res, 404,
           absl::StrCat("no such release file: ", EscapeUntrusted(req.target, 200),
                        " (a release tree holds only v1/blobs/sha256/HH/HEX, v1/catalogs/sha256/HH/HEX and "
                        "v1/channels/NAME.json)"));
    return;
  }
  auto file = tree.OpenFile(*path);
  if (!file.ok()) {
    Refuse(res, absl::IsNotFound(file.status()) ? 404 : 500, std::string(file.status().message()));
    return;
  }

  std::string etag;
  std::string content_type = "application/json";
  std::function<httplib::ContentProviderWithoutLength(ByteSpan)> provider_for;
  int64_t size = 0;
  if (path->immutable()) {
    if (const absl::Status verified = tree.Verify(*path, *file); !verified.ok()) {
      const int status = absl::IsUnavailable(verified) ? 503 : 500;
      if (status == 503) res.set_header("Retry-After", "1");
      Refuse(res, status, std::string(verified.message()));
      return;
    }
    etag = Quoted(path->name);
    res.set_header("Cache-Control", kImmutableCacheControl);
    if (path->kind == ReleaseFileKind::kBlob) content_type = "application/octet-stream";
    size = file->size_bytes();
    auto opened = std::make_shared<const OpenReleaseFile>(std::move(*file));
    provider_for = [opened, relative = path->relative](ByteSpan span) {
      return [opened, relative, span](size_t, httplib::DataSink& sink) {
        return StreamFile(*opened, span, relative, sink);
      };
    };
  } else {
    auto bytes = file->ReadAll(kMaxChannelBytes);
    if (!bytes.ok()) {
      Refuse(res, 500, absl::StrCat("release file ", path->relative, ": ", bytes.status().message()));
      return;
    }
    etag = Quoted(Sha256Hex(*bytes));
    res.set_header("Cache-Control", kChannelCacheControl);
    size = static_cast<int64_t>(bytes->size());
    auto held = std::make_shared<const std::string>(std::move(*bytes));
    provider_for = [held](ByteSpan span) {
      return [held, span](size_t, httplib::DataSink& sink) {
        if (span.length > 0 && !sink.write(held->data() + span.offset, static_cast<size_t>(span.length))) {
          return false;
        }
        sink.done();
        return true;
      };
    };
  }
  res.set_header("ETag", etag);
  res.set_header("Accept-Ranges", "bytes");
  res.set_header("X-Content-Type-Options", "nosniff");
  // A game's page is served from its own origin, not the farm's or the
  // CDN's: releases are public content (or token-guarded, which a browser
  // on another origin cannot present anyway), readable from any page.
  res.set_header("Access-Control-Allow-Origin", "*");
  res.set_header("Access-Control-Expose-Headers", "ETag, Content-Range, Content-Length");

  // Evaluated before Range (RFC 9110 section 13.2.2). The library adds
  // "Content-Length: 0" to a response without a body; a 304 should carry no
  // length or the 200's, but cpp-httplib's own client (0.11) reads a 304's
  // body by its Content-Length, or until the connection closes when there
  // is none, so 0 is what every client here reads correctly.
  if (const std::string inm = req.get_header_value("If-None-Match"); !inm.empty() && IfNoneMatchMatches(inm, etag)) {
    res.status = 304;
    return;
  }

  ByteSpan span{.offset = 0, .length = size};
  int status = 200;
  const bool range_applies =
      ranges.size() == 1 && (!req.has_header("If-Range") || req.get_header_value("If-Range") == etag);
  if (range_applies) {
    const auto asked = ResolveByteRange(ranges[0].first, ranges[0].second, size);
    if (!asked) {
      res.status = 416;
      res.set_header("Content-Range", absl::StrCat("bytes */", size));
      return;
    }
    span = *asked;
    status = 206;
    res.set_header("Content-Range", ContentRangeOf(span, size));
  }
  res.status = status;
  res.set_header("Content-Length", std::to_string(span.length));
  // A provider without a length, as blob_response.cc: given a length,
  // cpp-httplib would apply a Range itself, unclamped; without one, it
  // writes what the provider writes, under the headers set here, and never
  // compresses it.
  res.set_content_provider(content_type, provider_for(span));
}

}  // namespace impostor
