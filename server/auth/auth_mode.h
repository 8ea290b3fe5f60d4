// --auth none|token: whether the server asks callers for bearer tokens.
#ifndef IMPOSTOR_SERVER_AUTH_AUTH_MODE_H_
#define IMPOSTOR_SERVER_AUTH_AUTH_MODE_H_

#include <string>
#include <string_view>

#include "absl/status/statusor.h"

namespace impostor {

enum class AuthMode { kNone, kToken };

// `flag` is --auth ("" = not given), `listen` is --listen (HOST:PORT) and
// `http_listen` is --http-listen ("" = no HTTP front end), which serves the
// same jobs and assets. Not given: token unless every listener is on a
// loopback host. "none" with a listener on a non-loopback address is
// INVALID_ARGUMENT naming that flag and saying why: anyone who can reach the
// port could then bake, read every asset and publish forged results.
absl::StatusOr<AuthMode> ResolveAuthMode(std::string_view flag, std::string_view listen,
                                         std::string_view http_listen = "");

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_AUTH_AUTH_MODE_H_
