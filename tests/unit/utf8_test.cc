// common/util/utf8.h: cuts never split a character, and anything that is not
// UTF-8 becomes U+FFFD, so it can go into a proto string or JSON.
#include "common/util/utf8.h"

#include <string>

#include <gtest/gtest.h>

namespace impostor {
namespace {

bool IsValid(const std::string& s) { return ValidUtf8(s) == s; }

TEST(Utf8Prefix, NeverEndsInsideACharacter) {
  std::string text = "a";
  for (int i = 0; i < 100; ++i) text += "\xC3\xA9";  // é
  for (size_t max = 0; max <= text.size() + 1; ++max) {
    const std::string cut(Utf8Prefix(text, max));
    EXPECT_LE(cut.size(), max);
    EXPECT_GE(cut.size() + 1, std::min(max, text.size())) << "drops at most a partial character";
    EXPECT_TRUE(IsValid(cut)) << max;
  }
  const std::string emoji = "\xF0\x9F\x8C\xB3";  // 🌳, 4 bytes
  EXPECT_EQ(Utf8Prefix(emoji + emoji, 7), emoji);
  EXPECT_EQ(Utf8Prefix(emoji, 3), "");
}

TEST(ValidUtf8, ReplacesWhatIsNotUtf8AndKeepsWhatIs) {
  EXPECT_EQ(ValidUtf8("plain ascii"), "plain ascii");
  EXPECT_EQ(ValidUtf8("caf\xC3\xA9 \xF0\x9F\x8C\xB3"), "caf\xC3\xA9 \xF0\x9F\x8C\xB3");
  EXPECT_EQ(ValidUtf8("\xFF"), "\xEF\xBF\xBD");
  EXPECT_EQ(ValidUtf8("a\xC3"), "a\xEF\xBF\xBD") << "a cut sequence";
  EXPECT_EQ(ValidUtf8("\xC0\xAF"), "\xEF\xBF\xBD\xEF\xBF\xBD") << "overlong /";
  EXPECT_EQ(ValidUtf8("\xED\xA0\x80"), "\xEF\xBF\xBD\xEF\xBF\xBD\xEF\xBF\xBD") << "a surrogate";
  EXPECT_EQ(ValidUtf8("\xF4\x90\x80\x80").substr(0, 3), "\xEF\xBF\xBD") << "past U+10FFFF";
}

}  // namespace
}  // namespace impostor
