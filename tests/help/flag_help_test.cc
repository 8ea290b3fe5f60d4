// The --help generator itself (common/flags/flag_help.h) over flags defined here:
// grouping by prefix with the "Other" fallback, defaults, wrapping, and
// which arguments HandleHelpAndVersion answers.
#include "common/flags/flag_help.h"

#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "absl/flags/flag.h"

ABSL_FLAG(int, zz_listen_port, 50051, "Port to listen on (1..65535)");
ABSL_FLAG(bool, zz_listen_fast, true, "Listen quickly");
ABSL_FLAG(int64_t, zz_cache_bytes, int64_t{3} << 30, "Cache size, bytes (>= 0)");
ABSL_FLAG(std::string, zz_cache_dir, "", "Where the cache lives (default: next to the binary)");
ABSL_FLAG(std::string, zz_stray, "abc",
          "A flag that no group names, with a long help text that must be wrapped onto a second line because it "
          "runs well past eighty columns");

namespace impostor {
namespace {

ProgramHelp TestHelp() {
  return {.program = "zz-tool",
          .usage = {"--zz-listen-port=N [flags]", "--version"},
          .summary = "A test program.",
          .groups = {{"Listening", {"zz_listen_"}}, {"Cache", {"zz_cache_"}}, {"Unused", {"nothing_matches_"}}}};
}

// The lines of `text` from the heading `title` up to the next blank line.
std::vector<std::string> Section(const std::string& text, const std::string& title) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  bool inside = false;
  for (std::string line; std::getline(in, line);) {
    if (line == title + ":") {
      inside = true;
    } else if (inside && line.empty()) {
      break;
    } else if (inside) {
      lines.push_back(line);
    }
  }
  return lines;
}

TEST(FlagHelpTest, GroupsByPrefixAndListsTheRestUnderOther) {
  const std::string text = FlagHelpText(TestHelp());
  EXPECT_EQ(text.rfind("Usage: zz-tool --zz-listen-port=N [flags]\n       zz-tool --version\n", 0), 0u) << text;
  const std::vector<std::string> listening = Section(text, "Listening");
  ASSERT_EQ(listening.size(), 3u) << text;
  EXPECT_EQ(listening[0], "  --zz-listen-fast          Listen quickly (--nozz-listen-fast to turn off).");
  EXPECT_EQ(listening[1], "                            Default: true.");
  EXPECT_EQ(listening[2], "  --zz-listen-port=N        Port to listen on (1..65535). Default: 50051.");
  const std::vector<std::string> cache = Section(text, "Cache");
  ASSERT_EQ(cache.size(), 3u) << text;
  // Byte counts also in binary units, and a default is never split.
  EXPECT_EQ(cache[0], "  --zz-cache-bytes=N        Cache size, bytes (>= 0). Default:");
  EXPECT_EQ(cache[1], "                            3221225472 (3 GiB).");
  // An empty default that the help text explains is not repeated.
  EXPECT_EQ(cache[2], "  --zz-cache-dir=DIR        Where the cache lives (default: next to the binary).");
  EXPECT_TRUE(Section(text, "Unused").empty()) << "an empty group gets no heading";
  const std::vector<std::string> other = Section(text, "Other");
  ASSERT_EQ(other.size(), 3u) << text;
  EXPECT_EQ(other[0].rfind("  --zz-stray=TEXT           A flag that no group names", 0), 0u) << other[0];
  EXPECT_NE(other[2].find("Default: \"abc\"."), std::string::npos) << other[2];
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) EXPECT_LE(line.size(), 80u) << line;
}

TEST(FlagHelpTest, AnswersHelpAndVersionSpellingsOnly) {
  struct Case {
    std::vector<std::string> args;
    std::optional<int> status;
    std::string starts_with;
  };
  const std::vector<Case> cases = {
      {{"--help"}, 0, "Usage: zz-tool"},
      {{"-h"}, 0, "Usage: zz-tool"},
      {{"--zz-listen-port=1", "--helpfull"}, 0, "Usage: zz-tool"},
      {{"--helpshort"}, 0, "Usage: zz-tool"},
      {{"--version"}, 0, "zz-tool "},
      {{"--zz_listen_port=1"}, std::nullopt, ""},
      {{"--", "--help"}, std::nullopt, ""},  // after "--": an argument, not a flag
      {{"--helper=1"}, std::nullopt, ""},
  };
  for (const Case& c : cases) {
    std::vector<std::string> storage = {"zz-tool"};
    storage.insert(storage.end(), c.args.begin(), c.args.end());
    std::vector<char*> argv;
    for (std::string& s : storage) argv.push_back(s.data());
    ::testing::internal::CaptureStdout();
    const std::optional<int> status = HandleHelpAndVersion(static_cast<int>(argv.size()), argv.data(), TestHelp());
    const std::string out = ::testing::internal::GetCapturedStdout();
    SCOPED_TRACE(storage.back());
    EXPECT_EQ(status, c.status);
    EXPECT_EQ(out.rfind(c.starts_with, 0), 0u) << out;
    if (!c.status) EXPECT_EQ(out, "");
  }
}

}  // namespace
}  // namespace impostor
