// Where a client's bearer token comes from (issue 14): a token file
// (`--token-file FILE`), else a token given directly, else the
// IMPOSTOR_TOKEN environment variable; the file wins. Used by the `impostor`
// CLI, impostor-worker, the SDK, the cache and the C API alike.
#ifndef IMPOSTOR_COMMON_NET_TOKEN_SOURCE_H_
#define IMPOSTOR_COMMON_NET_TOKEN_SOURCE_H_

#include <string>

#include "absl/status/statusor.h"

namespace impostor {

inline constexpr char kTokenEnvVar[] = "IMPOSTOR_TOKEN";

// The token to send ("" = none). `token_file`: a file holding the token on
// its first line (surrounding whitespace ignored). `token`: the token
// itself. `env_token`: $IMPOSTOR_TOKEN's value or nullptr.
// INVALID_ARGUMENT naming the file (unreadable, empty, more than 4 KiB) or
// the source (a token with spaces or control characters); the message never
// contains the token.
absl::StatusOr<std::string> ResolveToken(const std::string& token_file, const std::string& token,
                                         const char* env_token);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_NET_TOKEN_SOURCE_H_
