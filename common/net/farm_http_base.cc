#include "common/net/farm_http_base.h"

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "common/util/sha256.h"

namespace impostor {

std::string ReprDigestSha256(std::string_view body) {
  return absl::StrCat("sha-256=:", absl::Base64Escape(absl::HexStringToBytes(Sha256Hex(body))), ":");
}

std::string_view ReprDigestSha256Member(std::string_view header) {
  for (absl::string_view member : absl::StrSplit(absl::string_view(header.data(), header.size()), ',')) {
    member = absl::StripAsciiWhitespace(member);
    if (absl::StartsWith(member, "sha-256=")) return std::string_view(member.data(), member.size());
  }
  return {};
}

absl::Status ValidateFarmHttpBase(absl::string_view url, bool tls) {
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

}  // namespace impostor
