#include "server/auth/auth_mode.h"

#include "absl/strings/str_cat.h"
#include "server/auth/loopback_host.h"

namespace impostor {

namespace {

bool OnLoopback(std::string_view address) {
  const size_t colon = address.rfind(':');
  return IsLoopbackHost(colon == std::string_view::npos ? address : address.substr(0, colon));
}

}  // namespace

absl::StatusOr<AuthMode> ResolveAuthMode(std::string_view flag, std::string_view listen,
                                         std::string_view http_listen) {
  // The first listener reachable from other machines, if any.
  std::string exposed;
  if (!OnLoopback(listen)) {
    exposed = absl::StrCat("--listen ", std::string(listen));
  } else if (!http_listen.empty() && !OnLoopback(http_listen)) {
    exposed = absl::StrCat("--http-listen ", std::string(http_listen));
  }
  if (flag.empty()) return exposed.empty() ? AuthMode::kNone : AuthMode::kToken;
  if (flag == "token") return AuthMode::kToken;
  if (flag != "none") {
    return absl::InvalidArgumentError(
        absl::StrCat("--auth: \"", std::string(flag), "\" is not a mode; expected none or token"));
  }
  if (!exposed.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--auth none: refused with ", exposed,
        ", which is not a loopback address: anyone who can reach the port "
        "could bake, read every asset and publish forged results. Use --auth token (the default there) or listen "
        "on 127.0.0.1"));
  }
  return AuthMode::kNone;
}

}  // namespace impostor
