// EscapeUntrusted / EscapeForTerminal (common/util/log_escape.h): strings from
// the network reach logs and terminals without control sequences, forged
// lines or unbounded length (issue 23).
#include "common/util/log_escape.h"

#include <gtest/gtest.h>

#include <string>

namespace impostor {
namespace {

TEST(LogEscape, ControlsQuotesAndBadBytesBecomeVisible) {
  struct Case {
    const char* name;
    std::string in;
    std::string log;       // EscapeUntrusted
    std::string terminal;  // EscapeForTerminal
  };
  const Case cases[] = {
      {"plain", "worker-1", "worker-1", "worker-1"},
      {"forged log line", "w\nevent=complete job=x", "w\\nevent=complete job=x", "w\\nevent=complete job=x"},
      {"terminal escape", "\x1b[2J\x1b]0;pwned\x07", "\\x1B[2J\\x1B]0;pwned\\x07", "\\x1B[2J\\x1B]0;pwned\\x07"},
      {"quotes", "a\"b\\c", "a\\\"b\\\\c", "a\"b\\c"},
      {"utf-8 kept", "caf\xC3\xA9 \xE6\xA8\xB9", "caf\xC3\xA9 \xE6\xA8\xB9", "caf\xC3\xA9 \xE6\xA8\xB9"},
      {"C1 CSI as UTF-8", "\xC2\x9B" "31m", "\\xC2\\x9B31m", "\\xC2\\x9B31m"},
      {"raw 8-bit CSI", "\x9B" "31m", "\\x9B31m", "\\x9B31m"},
      {"truncated sequence", "\xE6\xA8", "\\xE6\\xA8", "\\xE6\\xA8"},
      {"overlong slash", "\xC0\xAF", "\\xC0\\xAF", "\\xC0\\xAF"},
      {"NUL and DEL", std::string("a\0b\x7f", 4), "a\\x00b\\x7F", "a\\x00b\\x7F"},
  };
  for (const Case& c : cases) {
    EXPECT_EQ(EscapeUntrusted(c.in), c.log) << c.name;
    EXPECT_EQ(EscapeForTerminal(c.in), c.terminal) << c.name;
  }
}

TEST(LogEscape, LongTextIsCutOnACharacterBoundary) {
  const std::string long_text(10000, 'x');
  EXPECT_EQ(EscapeUntrusted(long_text, 8), "xxxxxxxx...(10000 bytes)");
  // Three 2-byte characters do not fit in 5 bytes: two are kept, whole.
  EXPECT_EQ(EscapeUntrusted("\xC3\xA9\xC3\xA9\xC3\xA9", 5), "\xC3\xA9\xC3\xA9...(6 bytes)");
  // An escape is never split either.
  EXPECT_EQ(EscapeUntrusted("ab\x1b", 4), "ab...(3 bytes)");
  EXPECT_EQ(EscapeUntrusted(std::string(512, 'y')).size(), 512u);
}

}  // namespace
}  // namespace impostor
