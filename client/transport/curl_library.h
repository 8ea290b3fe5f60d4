// libcurl, loaded when the first HTTP download (a mirror's, or a farm
// result's over the farm's HTTP front end) needs it rather than when a
// program starts.
//
// Why: libcurl and the 27 libraries it pulls in (GnuTLS, Kerberos, LDAP,
// SSH, RTMP, ...) cost every `impostor` run about 15 ms of CPU at start-up
// on the 2-core development machine (an empty program linked against
// libcurl: 16.9 against 1.4 ms, `perf stat -r 200`), a third of what
// `impostor --version` costs, although only downloads from mirrors
// (`--mirror`, `catalog ls`, a cache with mirrors) use it. Loading it with
// dlopen on first use keeps that cost off every other command: a CI job
// running `impostor bake` thousands of times, a fetch from the farm.
//
// The declarations and constants still come from <curl/curl.h>; only the
// functions are looked up at run time, each by its exported name.
#ifndef IMPOSTOR_CLIENT_TRANSPORT_CURL_LIBRARY_H_
#define IMPOSTOR_CLIENT_TRANSPORT_CURL_LIBRARY_H_

#include <curl/curl.h>

#include "absl/status/statusor.h"

namespace impostor::sdk {

// The libcurl functions the SDK calls.
struct CurlLibrary {
  decltype(&curl_global_init) global_init = nullptr;
  decltype(&curl_easy_init) easy_init = nullptr;
  decltype(&curl_easy_cleanup) easy_cleanup = nullptr;
  decltype(&curl_easy_reset) easy_reset = nullptr;
  decltype(&curl_easy_setopt) easy_setopt = nullptr;
  decltype(&curl_easy_perform) easy_perform = nullptr;
  decltype(&curl_easy_getinfo) easy_getinfo = nullptr;
  decltype(&curl_easy_strerror) easy_strerror = nullptr;
  decltype(&curl_slist_append) slist_append = nullptr;
  decltype(&curl_slist_free_all) slist_free_all = nullptr;
};

// The SONAME of Debian's libcurl4 (the OpenSSL flavour the SDK is built with).
inline constexpr const char kCurlSoname[] = "libcurl.so.4";

// The process's libcurl: loaded and initialised (curl_global_init) on the
// first call, from any thread; later calls return the same table, or the
// same error. FAILED_PRECONDITION naming the library and dlerror()'s reason
// when it cannot be loaded or lacks a function (install libcurl4).
absl::StatusOr<const CurlLibrary*> Curl();

// Loads `soname` afresh and looks the functions up, without initialising
// it: what Curl() does once. For tests of the error (a name that does not
// exist); the handle is kept open for the process's life.
absl::StatusOr<CurlLibrary> LoadCurlLibrary(const char* soname);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSPORT_CURL_LIBRARY_H_
