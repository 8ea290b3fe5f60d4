// Makes a string that came from the network (a worker id, a stage name, an
// error message, a client id) safe to put into a log line or onto a
// terminal: control characters (ESC sequences, newlines that forge log
// lines, C1 controls), backslashes, double quotes and bytes that are not
// UTF-8 become visible escapes, and the result is capped in length.
// Pure; thread-safe.
#ifndef IMPOSTOR_COMMON_UTIL_LOG_ESCAPE_H_
#define IMPOSTOR_COMMON_UTIL_LOG_ESCAPE_H_

#include <cstddef>
#include <string>
#include <string_view>

namespace impostor {

// Default cap of EscapeUntrusted's output, bytes before the suffix.
inline constexpr size_t kMaxUntrustedLogBytes = 512;

// `text` with: \n, \r, \t as "\n", "\r", "\t"; other bytes < 0x20, DEL,
// U+0080..U+009F and every byte that is not part of a valid UTF-8 sequence
// as "\xNN"; '\\' and '"' as "\\\\" and "\\\"" (so key="value" log fields
// stay parseable). Valid UTF-8 otherwise passes through. Output longer than
// `max_bytes` is cut at a character boundary and ends with
// "...(N bytes)" giving the input's length.
std::string EscapeUntrusted(std::string_view text, size_t max_bytes = kMaxUntrustedLogBytes);

// As EscapeUntrusted but '\\' and '"' pass through: for text shown to a
// person on a terminal (CLI errors, stage names), where quotes read better
// than escapes and only control sequences do harm.
std::string EscapeForTerminal(std::string_view text, size_t max_bytes = kMaxUntrustedLogBytes);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_UTIL_LOG_ESCAPE_H_
