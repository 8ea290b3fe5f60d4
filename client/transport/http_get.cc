#include "client/transport/http_get.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/string_view.h"
#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "client/transport/curl_library.h"

namespace impostor::sdk {
namespace {

struct Transfer {
  const HttpGetOptions* options;
  const std::function<absl::Status(std::string_view)>* sink;
  HttpGetResult result;
  long header_status = 0;  // of the response whose headers came last
  absl::Status sink_error;
};

size_t OnHeader(char* data, size_t size, size_t count, void* user) {
  auto* t = static_cast<Transfer*>(user);
  absl::string_view line(data, size * count);
  line = absl::StripTrailingAsciiWhitespace(line);
  if (absl::StartsWith(line, "HTTP/")) {
    // A new response (after a redirect or a 100): forget the last one's.
    const size_t space = line.find(' ');
    long status = 0;
    if (space != absl::string_view::npos) (void)absl::SimpleAtoi(line.substr(space + 1, 3), &status);
    t->header_status = status;
    t->result.etag.clear();
    t->result.content_type.clear();
    t->result.range_start = 0;
    t->result.repr_digest.clear();
    t->result.error_body.clear();
    return size * count;
  }
  const size_t colon = line.find(':');
  if (colon == absl::string_view::npos) return size * count;
  const std::string name = absl::AsciiStrToLower(line.substr(0, colon));
  absl::string_view value = absl::StripAsciiWhitespace(line.substr(colon + 1));
  if (name == "etag") t->result.etag = std::string(value);
  if (name == "content-type") t->result.content_type = std::string(value);
  if (name == "repr-digest") t->result.repr_digest = std::string(value);
  if (name == "content-range") {
    // "bytes START-END/TOTAL"
    absl::string_view v = value;
    if (absl::ConsumePrefix(&v, "bytes ")) {
      const size_t dash = v.find('-');
      int64_t start = 0;
      if (dash != absl::string_view::npos && absl::SimpleAtoi(v.substr(0, dash), &start)) t->result.range_start = start;
    }
  }
  return size * count;
}

size_t OnBody(char* data, size_t size, size_t count, void* user) {
  auto* t = static_cast<Transfer*>(user);
  const size_t n = size * count;
  // Only a file's bytes reach the sink: an error page's body is kept up to
  // a few KiB for the caller's message.
  if (t->header_status != 200 && t->header_status != 206) {
    std::string& kept = t->result.error_body;
    kept.append(data, std::min(n, HttpGetResult::kErrorBodyBytes - std::min(kept.size(), HttpGetResult::kErrorBodyBytes)));
    return n;
  }
  if (t->result.body_bytes + static_cast<int64_t>(n) > t->options->max_body_bytes) {
    t->sink_error = absl::DataLossError(absl::StrCat("the body is longer than the ", t->options->max_body_bytes,
                                                     " bytes expected"));
    return 0;
  }
  if (absl::Status s = (*t->sink)(std::string_view(data, n)); !s.ok()) {
    t->sink_error = std::move(s);
    return 0;
  }
  t->result.body_bytes += static_cast<int64_t>(n);
  return n;
}

int OnProgress(void* user, curl_off_t, curl_off_t, curl_off_t, curl_off_t) {
  auto* t = static_cast<Transfer*>(user);
  return t->options->cancel != nullptr && t->options->cancel->cancelled() ? 1 : 0;
}

// One easy handle per thread: curl keeps its connections (and DNS answers)
// with the handle, so a thread fetching many files from one mirror reuses
// its connection. The options every transfer shares are set once per
// handle rather than reset and set again for each file (curl_easy_reset
// frees and rebuilds all of the handle's settings).
struct ThreadHandle {
  explicit ThreadHandle(const CurlLibrary* lib) : lib(lib), curl(lib->easy_init()) {}
  ~ThreadHandle() {
    if (curl != nullptr) lib->easy_cleanup(curl);
  }
  const CurlLibrary* lib;
  CURL* curl;
  bool configured = false;
  std::string ca_file;  // what CURLOPT_CAINFO was set to ("" = the system's)
  long buffer_bytes = CURL_MAX_WRITE_SIZE;  // CURLOPT_BUFFERSIZE (libcurl's default)
};

// The options that are the same for every transfer, and the CA bundle
// (which changes only when one thread serves caches of different settings).
void Configure(ThreadHandle& handle, const std::string& ca_file) {
  const CurlLibrary& lib = *handle.lib;
  CURL* curl = handle.curl;
  lib.easy_reset(curl);
  lib.easy_setopt(curl, CURLOPT_NOSIGNAL, 1L);
  lib.easy_setopt(curl, CURLOPT_FOLLOWLOCATION, 1L);
  lib.easy_setopt(curl, CURLOPT_MAXREDIRS, 5L);
  lib.easy_setopt(curl, CURLOPT_PROTOCOLS_STR, "http,https");
  lib.easy_setopt(curl, CURLOPT_REDIR_PROTOCOLS_STR, "http,https");
  lib.easy_setopt(curl, CURLOPT_HEADERFUNCTION, &OnHeader);
  lib.easy_setopt(curl, CURLOPT_WRITEFUNCTION, &OnBody);
  lib.easy_setopt(curl, CURLOPT_NOPROGRESS, 0L);
  lib.easy_setopt(curl, CURLOPT_XFERINFOFUNCTION, &OnProgress);
  lib.easy_setopt(curl, CURLOPT_USERAGENT, "impostor-sdk/1");
  if (!ca_file.empty()) lib.easy_setopt(curl, CURLOPT_CAINFO, ca_file.c_str());
  handle.configured = true;
  handle.ca_file = ca_file;
  handle.buffer_bytes = CURL_MAX_WRITE_SIZE;  // easy_reset restored the default
}

}  // namespace

absl::StatusOr<HttpGetResult> HttpGet(const std::string& url, const HttpGetOptions& options,
                                      const std::function<absl::Status(std::string_view)>& sink,
                                      int64_t* partial_bytes) {
  absl::StatusOr<const CurlLibrary*> loaded = Curl();
  if (!loaded.ok()) return loaded.status();
  const CurlLibrary& lib = **loaded;
  thread_local ThreadHandle handle(&lib);
  if (handle.curl == nullptr) return absl::InternalError("libcurl: cannot create a handle");
  if (options.cancel != nullptr && options.cancel->cancelled()) return options.cancel->error();
  if (!handle.configured || handle.ca_file != options.ca_file) Configure(handle, options.ca_file);
  CURL* curl = handle.curl;
  Transfer t{&options, &sink, {}, 0, absl::OkStatus()};
  const long stall_ms = static_cast<long>(std::ceil(options.stall_seconds * 1000));
  // Every option that differs between transfers is set for each one,
  // cleared ones included (no Range, no If-None-Match).
  lib.easy_setopt(curl, CURLOPT_URL, url.c_str());
  lib.easy_setopt(curl, CURLOPT_CONNECTTIMEOUT_MS, stall_ms);
  // A transfer that moves less than one byte a second for the stall time
  // has stalled (curl counts whole seconds).
  lib.easy_setopt(curl, CURLOPT_LOW_SPEED_LIMIT, 1L);
  lib.easy_setopt(curl, CURLOPT_LOW_SPEED_TIME, std::max(1L, (stall_ms + 999) / 1000));
  lib.easy_setopt(curl, CURLOPT_HEADERDATA, &t);
  lib.easy_setopt(curl, CURLOPT_WRITEDATA, &t);
  lib.easy_setopt(curl, CURLOPT_XFERINFODATA, &t);
  // libcurl's own 16 KiB unless asked (each handle keeps its buffer, and a
  // fleet of players holds a handle per download thread); set only when it
  // changes.
  const long buffer = options.receive_buffer_bytes > 0 ? options.receive_buffer_bytes : long{CURL_MAX_WRITE_SIZE};
  if (buffer != handle.buffer_bytes) {
    lib.easy_setopt(curl, CURLOPT_BUFFERSIZE, buffer);
    handle.buffer_bytes = buffer;
  }
  std::string range;
  if (options.offset > 0) range = absl::StrCat(options.offset, "-");
  lib.easy_setopt(curl, CURLOPT_RANGE, range.empty() ? nullptr : range.c_str());
  curl_slist* headers = nullptr;
  if (!options.if_none_match.empty()) {
    headers = lib.slist_append(headers, absl::StrCat("If-None-Match: ", options.if_none_match).c_str());
  }
  if (!options.authorization.empty()) {
    headers = lib.slist_append(headers, absl::StrCat("Authorization: ", options.authorization).c_str());
  }
  lib.easy_setopt(curl, CURLOPT_HTTPHEADER, headers);
  const CURLcode code = lib.easy_perform(curl);
  // The handle keeps no pointer to this call's header list.
  lib.easy_setopt(curl, CURLOPT_HTTPHEADER, static_cast<curl_slist*>(nullptr));
  lib.slist_free_all(headers);
  if (partial_bytes != nullptr) *partial_bytes = t.result.body_bytes;
  long status = 0;
  lib.easy_getinfo(curl, CURLINFO_RESPONSE_CODE, &status);
  t.result.status = status;
  if (code == CURLE_OK) return t.result;
  if (code == CURLE_WRITE_ERROR && !t.sink_error.ok()) return t.sink_error;
  if (code == CURLE_ABORTED_BY_CALLBACK && options.cancel != nullptr) return options.cancel->error();
  const std::string what = absl::StrCat(url, ": ", lib.easy_strerror(code));
  switch (code) {
    case CURLE_OPERATION_TIMEDOUT:
      return absl::DeadlineExceededError(absl::StrCat(what, " (no byte for ", options.stall_seconds,
                                                      " s: the link stalled, after ", t.result.body_bytes,
                                                      " bytes)"));
    case CURLE_URL_MALFORMAT:
    case CURLE_UNSUPPORTED_PROTOCOL:
      return absl::InvalidArgumentError(what);
    default:
      return absl::UnavailableError(absl::StrCat(what, " (after ", t.result.body_bytes, " bytes)"));
  }
}

}  // namespace impostor::sdk
