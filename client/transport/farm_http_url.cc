#include "client/transport/farm_http_url.h"

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/strip.h"

namespace impostor::sdk {

absl::Status ValidateFarmHttpUrl(absl::string_view url, bool tls) {
  if (url.size() > kMaxFarmHttpUrlBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("the URL is ", url.size(), " bytes, over the limit of ", kMaxFarmHttpUrlBytes));
  }
  for (unsigned char c : url) {
    if (c <= 0x20 || c >= 0x7f) {
      return absl::InvalidArgumentError("the URL holds a space, a control or a non-ASCII character");
    }
  }
  absl::string_view rest = url;
  const bool https = absl::ConsumePrefix(&rest, "https://");
  if (!https && !absl::ConsumePrefix(&rest, "http://")) {
    return absl::InvalidArgumentError(absl::StrCat("\"", url, "\" is not an http:// or https:// URL"));
  }
  if (rest.empty() || rest.front() == '/' || rest.front() == ':') {
    return absl::InvalidArgumentError(absl::StrCat("\"", url, "\" names no host"));
  }
  if (rest.find_first_of("?#") != absl::string_view::npos) {
    return absl::InvalidArgumentError(absl::StrCat("\"", url, "\" has a query or a fragment; give the base URL"));
  }
  if (rest.find('@') != absl::string_view::npos) {
    return absl::InvalidArgumentError(
        absl::StrCat("\"", url, "\" carries credentials; the token goes in the Authorization header"));
  }
  if (tls && !https) {
    return absl::InvalidArgumentError(absl::StrCat(
        "\"", url, "\" is plaintext while the farm's gRPC is TLS: the token would cross the network in clear; "
                   "give an https:// URL (a TLS proxy in front of --http-listen)"));
  }
  return absl::OkStatus();
}

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
  if (absl::Status s = ValidateFarmHttpUrl(url, tls); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(named, ": ", s.message()));
  }
  while (absl::EndsWith(url, "/")) url.pop_back();
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
