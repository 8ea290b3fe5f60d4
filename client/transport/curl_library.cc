#include "client/transport/curl_library.h"

#include <dlfcn.h>

#include <string>

#include "absl/strings/str_cat.h"

namespace impostor::sdk {
namespace {

absl::Status LoadError(const char* soname, const char* what) {
  const char* reason = dlerror();
  return absl::FailedPreconditionError(absl::StrCat(
      "HTTP downloads (mirrors, a farm's HTTP front end) need libcurl (", soname, "; Debian package libcurl4): ", what,
      reason != nullptr ? absl::StrCat(": ", reason) : std::string()));
}

template <typename Fn>
bool Find(void* handle, const char* name, Fn* fn) {
  *fn = reinterpret_cast<Fn>(dlsym(handle, name));
  return *fn != nullptr;
}

}  // namespace

absl::StatusOr<CurlLibrary> LoadCurlLibrary(const char* soname) {
  dlerror();
  void* handle = dlopen(soname, RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) return LoadError(soname, "cannot load it");
  CurlLibrary lib;
  const bool found = Find(handle, "curl_global_init", &lib.global_init) &&
                     Find(handle, "curl_easy_init", &lib.easy_init) &&
                     Find(handle, "curl_easy_cleanup", &lib.easy_cleanup) &&
                     Find(handle, "curl_easy_reset", &lib.easy_reset) &&
                     Find(handle, "curl_easy_setopt", &lib.easy_setopt) &&
                     Find(handle, "curl_easy_perform", &lib.easy_perform) &&
                     Find(handle, "curl_easy_getinfo", &lib.easy_getinfo) &&
                     Find(handle, "curl_easy_strerror", &lib.easy_strerror) &&
                     Find(handle, "curl_slist_append", &lib.slist_append) &&
                     Find(handle, "curl_slist_free_all", &lib.slist_free_all);
  if (!found) {
    absl::Status error = LoadError(soname, "a function is missing");
    dlclose(handle);
    return error;
  }
  return lib;  // the handle stays open: its functions are used until exit
}

absl::StatusOr<const CurlLibrary*> Curl() {
  // Never destroyed: transfers on other threads may outlive static
  // destructors.
  static const auto* const loaded = [] {
    auto* result = new absl::StatusOr<CurlLibrary>(LoadCurlLibrary(kCurlSoname));
    if (result->ok() && (*result)->global_init(CURL_GLOBAL_DEFAULT) != CURLE_OK) {
      *result = absl::FailedPreconditionError(
          absl::StrCat("HTTP downloads (mirrors, a farm's HTTP front end) need libcurl (", kCurlSoname, "): curl_global_init failed"));
    }
    return result;
  }();
  if (!loaded->ok()) return loaded->status();
  return &**loaded;
}

}  // namespace impostor::sdk
