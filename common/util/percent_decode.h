// Percent-decoding of glTF resource URIs (RFC 3986 escapes), shared by the
// client (collecting a model's files) and the worker (resolving them), so
// both read a URI the same way. Pure; thread-safe.
#ifndef IMPOSTOR_COMMON_UTIL_PERCENT_DECODE_H_
#define IMPOSTOR_COMMON_UTIL_PERCENT_DECODE_H_

#include <string>
#include <string_view>

#include "absl/status/statusor.h"

namespace impostor {

// "a%20b" -> "a b". INVALID_ARGUMENT naming the byte offset for a truncated
// or non-hex escape, and for a NUL byte (raw or escaped), which no file path
// may contain.
absl::StatusOr<std::string> PercentDecode(std::string_view uri);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_UTIL_PERCENT_DECODE_H_
