// --auth none|token: whether the server asks callers for bearer tokens.
#ifndef IMPOSTOR_SERVER_AUTH_MODE_H_
#define IMPOSTOR_SERVER_AUTH_MODE_H_

#include <string>
#include <string_view>

#include "absl/status/statusor.h"

namespace impostor {

enum class AuthMode { kNone, kToken };

// True for localhost, 127.0.0.0/8 and ::1 (with or without brackets).
bool IsLoopbackHost(std::string_view host);

// `flag` is --auth ("" = not given), `listen` is --listen (HOST:PORT).
// Not given: token unless the host is loopback. "none" on a non-loopback
// address is INVALID_ARGUMENT saying why: anyone who can reach the port
// could then bake, read every asset and publish forged results.
absl::StatusOr<AuthMode> ResolveAuthMode(std::string_view flag, std::string_view listen);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_AUTH_MODE_H_
