#include "client/transfer/http_blob_read.h"

#include "absl/strings/string_view.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "client/transport/http_get.h"

namespace impostor::sdk {
namespace {

constexpr int64_t kLargeReadBytes = int64_t{1} << 20;
constexpr long kLargeReceiveBuffer = 256L << 10;

}  // namespace

absl::Status ReadVerified(const std::string& url, absl::string_view sha256, int64_t size_bytes, int64_t offset,
                          Sha256& hash, const std::function<absl::Status(std::string_view)>& sink,
                          const HttpReadOptions& options) {
  if (offset < 0 || offset > size_bytes) {
    return absl::InvalidArgumentError(absl::StrCat(url, ": offset ", offset, " outside 0..", size_bytes));
  }
  int64_t have = offset;
  int fruitless = 0;  // transfers in a row that brought nothing
  absl::Status last = absl::OkStatus();
  while (have < size_bytes) {
    if (options.cancel != nullptr && options.cancel->cancelled()) return options.cancel->error();
    HttpGetOptions get;
    get.stall_seconds = options.stall_seconds;
    get.offset = have;
    get.cancel = options.cancel;
    get.ca_file = options.ca_file;
    get.authorization = options.authorization;
    // Large reads for a large file only: small ones are most of a game's
    // (a handle keeps its buffer).
    if (size_bytes - have >= kLargeReadBytes) get.receive_buffer_bytes = kLargeReceiveBuffer;
    int64_t received = 0;
    absl::StatusOr<HttpGetResult> got = HttpGet(
        url, get,
        [&](std::string_view data) -> absl::Status {
          if (have + static_cast<int64_t>(data.size()) > size_bytes) {
            return absl::DataLossError(absl::StrCat(url, ": more than the ", size_bytes, " bytes of blob ", sha256,
                                                    " (an error page or another file?)"));
          }
          hash.Update(data);
          if (absl::Status s = sink(data); !s.ok()) return s;
          have += static_cast<int64_t>(data.size());
          received += static_cast<int64_t>(data.size());
          return absl::OkStatus();
        },
        nullptr);
    if (got.ok()) {
      if (got->status == 404 || got->status == 410) {
        return absl::NotFoundError(absl::StrCat(url, ": HTTP ", got->status, " (the server has no blob ", sha256, ")"));
      }
      if (got->status == 416) {
        return absl::DataLossError(absl::StrCat(url, ": HTTP 416 for bytes ", have, "- of blob ", sha256,
                                                ": the served file is shorter than the digest's ", size_bytes,
                                                " bytes"));
      }
      if (got->status != 200 && got->status != 206) {
        return absl::UnavailableError(absl::StrCat(url, ": HTTP ", got->status));
      }
      // Our files are never served as HTML: a 200 text/html is a CDN's or
      // proxy's error page (its bytes were fed on; the caller drops them).
      if (absl::StartsWithIgnoreCase(got->content_type, "text/html")) {
        return absl::DataLossError(absl::StrCat(url, ": HTTP ", got->status, " with an HTML page (",
                                                got->content_type, ", ", received, " bytes), not blob ", sha256,
                                                ": an error page served as success"));
      }
      if (got->status == 206 && got->range_start != have - received) {
        return absl::DataLossError(absl::StrCat(url, ": asked for bytes from ", have - received,
                                                ", the server sent them from ", got->range_start));
      }
      if (got->status == 200 && have - received > 0) {
        // The whole file came although we asked for a range, and was fed
        // on as if it followed our bytes: the caller starts over from zero
        // (a mirror that ignores Range still serves whole files).
        return absl::DataLossError(absl::StrCat(url, ": the server ignored the Range request (HTTP 200 for bytes ",
                                                have - received, "-); fetching from zero"));
      }
      if (have < size_bytes) {
        // The mirror said it was done but sent too little: a truncated file
        // (or a body cut without a Content-Length). Ask for the rest.
        last = absl::UnavailableError(absl::StrCat(url, ": the body ended after ", have, " of ", size_bytes,
                                                   " bytes of blob ", sha256));
      }
    } else {
      if (got.status().code() == absl::StatusCode::kDataLoss || got.status().code() == absl::StatusCode::kCancelled ||
          got.status().code() == absl::StatusCode::kInvalidArgument) {
        return got.status();
      }
      if (!absl::IsUnavailable(got.status()) && !absl::IsDeadlineExceeded(got.status())) return got.status();
      last = got.status();
    }
    if (have >= size_bytes) break;
    fruitless = received > 0 ? 0 : fruitless + 1;
    if (fruitless >= options.max_attempts) {
      if (absl::IsUnavailable(last) && last.message().find("the body ended") != absl::string_view::npos) {
        return absl::DataLossError(absl::StrCat(last.message(), " (truncated on the server)"));
      }
      return last;
    }
  }
  const std::string actual = hash.FinishHex();
  if (actual != sha256) {
    return absl::DataLossError(absl::StrCat(url, ": the bytes hash to ", actual, ", not to blob ", sha256,
                                            " (a wrong byte, or an error page served as 200)"));
  }
  return absl::OkStatus();
}

absl::StatusOr<std::string> ReadVerifiedToString(const std::string& url, absl::string_view sha256,
                                                 int64_t size_bytes, const HttpReadOptions& options) {
  std::string out;
  Sha256 hash;
  absl::Status s = ReadVerified(url, sha256, size_bytes, 0, hash,
                                [&](std::string_view data) {
                                  out.append(data);
                                  return absl::OkStatus();
                                },
                                options);
  if (!s.ok()) return s;
  return out;
}

}  // namespace impostor::sdk
