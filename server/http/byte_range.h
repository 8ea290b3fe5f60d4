// One range of an HTTP "Range: bytes=..." header (RFC 9110 section 14.1.2)
// resolved against the size of the body it asks into. cpp-httplib parses
// the header into (first, last) pairs, -1 for a part left out, but then
// trusts them as given: a last byte past the end went out in Content-Range
// and Content-Length unclamped. This clamps it, as the RFC says.
#ifndef IMPOSTOR_SERVER_HTTP_BYTE_RANGE_H_
#define IMPOSTOR_SERVER_HTTP_BYTE_RANGE_H_

#include <cstdint>
#include <optional>
#include <string>

namespace impostor {

struct ByteSpan {
  int64_t offset = 0;
  int64_t length = 0;  // > 0
};

// The bytes of a `size`-byte body that the range (first, last) asks for:
//   first-last   from first to last, last clamped to the final byte
//   first-       (last -1) from first to the end
//   -n           (first -1) the final n bytes, the whole body if n > size
// nullopt when nothing can be served: first at or past the end (which any
// range of an empty body is), a zero-length suffix, or neither part given.
std::optional<ByteSpan> ResolveByteRange(int64_t first, int64_t last, int64_t size);

// "bytes OFFSET-LAST/SIZE", the Content-Range of a 206.
std::string ContentRangeOf(const ByteSpan& span, int64_t size);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_HTTP_BYTE_RANGE_H_
