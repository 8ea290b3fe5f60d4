#include "client/transport/farm_http_url.h"

#include "common/net/farm_http_base.h"

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/strip.h"

namespace impostor::sdk {

absl::StatusOr<std::string> ResolveFarmHttp(absl::string_view configured, absl::string_view field, const char* env,
                                            bool tls) {
  std::string url(configured);
  std::string named(field);
  if (url.empty()) {
    if (env == nullptr || *env == '\0') return std::string();
    url = env;
    named = absl::StrCat("$", kFarmHttpEnvVar);
  }
  if (url == "none") return std::string();
  if (absl::Status s = ValidateFarmHttpBase(url, tls); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(named, ": ", s.message()));
  }
  while (absl::EndsWith(url, "/")) url.pop_back();
  return url;
}

bool FarmHttpTurnedOff(absl::string_view configured, const char* env) {
  if (!configured.empty()) return configured == "none";
  return env != nullptr && absl::string_view(env) == "none";
}

absl::StatusOr<std::string> AdvertisedFarmHttp(absl::string_view value, bool tls) {
  if (absl::Status s = ValidateFarmHttpBase(value, tls); !s.ok()) return s;
  std::string url(value);
  while (absl::EndsWith(url, "/")) url.pop_back();
  return url;
}

std::string ResultManifestUrl(absl::string_view base, absl::string_view cache_key) {
  std::string url(base);
  while (!url.empty() && url.back() == '/') url.pop_back();
  absl::StrAppend(&url, "/api/v1/results/", cache_key, "/manifest");
  return url;
}

std::string ResultFileUrl(absl::string_view base, absl::string_view cache_key, absl::string_view file_name) {
  std::string url(base);
  while (!url.empty() && url.back() == '/') url.pop_back();
  absl::StrAppend(&url, "/api/v1/results/", cache_key, "/files/");
  for (unsigned char c : file_name) {
    if (absl::ascii_isalnum(c) || c == '-' || c == '.' || c == '_' || c == '~') {
      url.push_back(static_cast<char>(c));
    } else {
      absl::StrAppendFormat(&url, "%%%02X", c);
    }
  }
  return url;
}

}  // namespace impostor::sdk
