// The benches' command-line parser (bench/bench_args.h): values in both
// spellings, positional arguments, and every bad input ends the program with
// exit code 2 naming the flag before a bench starts work.
#include "bench/bench_args.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace impostor::bench {
namespace {

struct Parsed {
  uint32_t frames = 12;
  int views = 16;
  double seconds = 5.0;
  std::string out = "default.md";
  std::vector<std::string> rpcs;
  bool on_frames = false;
  std::vector<std::string> assets;
};

void Parse(std::vector<std::string> args, Parsed* p) {
  args.insert(args.begin(), "bench");
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  BenchArgs("bench", "a test bench")
      .Uint("--frames", &p->frames, "frames")
      .Int("--views", &p->views, "views")
      .Real("--seconds", &p->seconds, "seconds")
      .Text("--out", &p->out, "output")
      .Texts("--rpc", &p->rpcs, "rpcs")
      .Switch("--on-frames", &p->on_frames, "switch")
      .Positional("ASSET", &p->assets, "assets")
      .ParseOrExit(static_cast<int>(argv.size()), argv.data());
}

TEST(BenchArgs, ReadsValuesInBothSpellingsAndKeepsDefaults) {
  Parsed p;
  Parse({"--frames", "8", "--views=-3", "--seconds", "0.25", "--rpc", "health", "--rpc=lookup", "a.glb",
         "--on-frames", "b.glb"},
        &p);
  EXPECT_EQ(p.frames, 8u);
  EXPECT_EQ(p.views, -3);
  EXPECT_DOUBLE_EQ(p.seconds, 0.25);
  EXPECT_EQ(p.out, "default.md");
  EXPECT_EQ(p.rpcs, (std::vector<std::string>{"health", "lookup"}));
  EXPECT_TRUE(p.on_frames);
  EXPECT_EQ(p.assets, (std::vector<std::string>{"a.glb", "b.glb"}));
}

TEST(BenchArgsDeathTest, UnknownFlagExitsWithTwoNamingIt) {
  Parsed p;
  EXPECT_EXIT(Parse({"--frame", "8"}, &p), testing::ExitedWithCode(2), "bench: unknown flag --frame");
}

TEST(BenchArgsDeathTest, MissingValueExitsWithTwo) {
  Parsed p;
  EXPECT_EXIT(Parse({"--out"}, &p), testing::ExitedWithCode(2), "--out needs a value");
}

TEST(BenchArgsDeathTest, MalformedNumbersExitWithTwo) {
  Parsed p;
  EXPECT_EXIT(Parse({"--frames", "12x"}, &p), testing::ExitedWithCode(2), "--frames: '12x' is not a whole number");
  EXPECT_EXIT(Parse({"--frames=-1"}, &p), testing::ExitedWithCode(2), "--frames: '-1' is not a whole number");
  EXPECT_EXIT(Parse({"--views", ""}, &p), testing::ExitedWithCode(2), "--views: '' is not a whole number");
  EXPECT_EXIT(Parse({"--seconds", "fast"}, &p), testing::ExitedWithCode(2), "--seconds: 'fast' is not a number");
}

TEST(BenchArgsDeathTest, SwitchTakesNoValue) {
  Parsed p;
  EXPECT_EXIT(Parse({"--on-frames=yes"}, &p), testing::ExitedWithCode(2), "--on-frames takes no value");
}

TEST(BenchArgsDeathTest, HelpPrintsEveryFlagAndExitsWithZero) {
  Parsed p;
  EXPECT_EXIT(
      {
        Parse({"--help"}, &p);
      },
      testing::ExitedWithCode(0), "");
}

TEST(BenchArgsDeathTest, PositionalWithoutDeclarationIsAnError) {
  std::vector<std::string> args = {"bench", "stray"};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  int n = 0;
  EXPECT_EXIT(BenchArgs("bench", "").Int("--n", &n, "n").ParseOrExit(2, argv.data()), testing::ExitedWithCode(2),
              "unexpected argument 'stray'");
}

}  // namespace
}  // namespace impostor::bench
