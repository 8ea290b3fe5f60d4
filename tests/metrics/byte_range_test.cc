// ResolveByteRange: one range of a Range header against a body's size, as
// RFC 9110 section 14.1.2 reads, every case named.
#include <gtest/gtest.h>

#include "server/http/byte_range.h"

namespace impostor {
namespace {

TEST(ByteRange, ResolvesAgainstTheSize) {
  struct Case {
    const char* name;
    int64_t first, last, size;
    bool satisfiable;
    int64_t offset, length;
  };
  const Case cases[] = {
      {"first-last inside", 0, 99, 1000, true, 0, 100},
      {"one byte", 5, 5, 1000, true, 5, 1},
      {"last byte past the end is clamped", 990, 5000, 1000, true, 990, 10},
      {"open end", 400, -1, 1000, true, 400, 600},
      {"last byte only", 999, -1, 1000, true, 999, 1},
      {"suffix", -1, 10, 1000, true, 990, 10},
      {"suffix longer than the body", -1, 5000, 1000, true, 0, 1000},
      {"first at the end", 1000, -1, 1000, false, 0, 0},
      {"first past the end", 2000, 3000, 1000, false, 0, 0},
      {"zero-length suffix", -1, 0, 1000, false, 0, 0},
      {"neither part", -1, -1, 1000, false, 0, 0},
      {"any range of an empty body", 0, -1, 0, false, 0, 0},
      {"a suffix of an empty body", -1, 5, 0, false, 0, 0},
  };
  for (const Case& c : cases) {
    const auto span = ResolveByteRange(c.first, c.last, c.size);
    ASSERT_EQ(span.has_value(), c.satisfiable) << c.name;
    if (!span) continue;
    EXPECT_EQ(span->offset, c.offset) << c.name;
    EXPECT_EQ(span->length, c.length) << c.name;
  }
}

TEST(ByteRange, ContentRangeNamesTheLastByteAndTheSize) {
  EXPECT_EQ(ContentRangeOf({.offset = 990, .length = 10}, 1000), "bytes 990-999/1000");
  EXPECT_EQ(ContentRangeOf({.offset = 0, .length = 1}, 1), "bytes 0-0/1");
}

}  // namespace
}  // namespace impostor
