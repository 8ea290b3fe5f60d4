// UTF-8 for strings that callers send and the farm stores or echoes. A
// proto3 string must be valid UTF-8 (a stored record that is not no longer
// parses) and so must JSON; a byte-count cut can split a character.
#ifndef IMPOSTOR_COMMON_UTIL_UTF8_H_
#define IMPOSTOR_COMMON_UTIL_UTF8_H_

#include <cstddef>
#include <string>
#include <string_view>

namespace impostor {

// The longest prefix of `text` of at most `max_bytes` bytes that does not
// end inside a character (of valid UTF-8 input, valid UTF-8 comes out).
std::string_view Utf8Prefix(std::string_view text, size_t max_bytes);

// `text` with every byte that is not part of a valid UTF-8 sequence
// replaced by U+FFFD, so it can go into a proto string or JSON.
std::string ValidUtf8(std::string_view text);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_UTIL_UTF8_H_
