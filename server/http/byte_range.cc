#include "server/http/byte_range.h"

#include <algorithm>

#include "absl/strings/str_cat.h"

namespace impostor {

std::optional<ByteSpan> ResolveByteRange(int64_t first, int64_t last, int64_t size) {
  if (first < 0) {  // a suffix: the final `last` bytes
    if (last <= 0 || size == 0) return std::nullopt;
    const int64_t length = std::min(last, size);
    return ByteSpan{.offset = size - length, .length = length};
  }
  if (first >= size) return std::nullopt;
  const int64_t end = last < 0 ? size - 1 : std::min(last, size - 1);
  if (end < first) return std::nullopt;
  return ByteSpan{.offset = first, .length = end - first + 1};
}

std::string ContentRangeOf(const ByteSpan& span, int64_t size) {
  return absl::StrCat("bytes ", span.offset, "-", span.offset + span.length - 1, "/", size);
}

}  // namespace impostor
