#include "common/util/percent_decode.h"

#include <gtest/gtest.h>

namespace impostor {
namespace {

TEST(PercentDecode, DecodesEscapesAndRefusesMalformedOnes) {
  EXPECT_EQ(*PercentDecode("Box%20With%20Spaces.bin"), "Box With Spaces.bin");
  EXPECT_EQ(*PercentDecode("a%2Fb%2fc"), "a/b/c");
  EXPECT_EQ(*PercentDecode("plain.png"), "plain.png");
  struct Case {
    const char* name;
    std::string_view uri;
  } bad[] = {{"truncated", "a%2"}, {"not hex", "a%zz"}, {"escaped NUL", "a%00b"},
             {"raw NUL", std::string_view("a\0b", 3)}};
  for (const Case& c : bad) {
    const auto r = PercentDecode(c.uri);
    EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument) << c.name;
  }
}

}  // namespace
}  // namespace impostor
