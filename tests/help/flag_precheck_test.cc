// The daemons' command-line check before Abseil parses it
// (common/flags/flag_precheck.h), over flags defined here, and as the real
// binaries see it: what Abseil would refuse with exit 1 is a usage error,
// exit 2, naming the flag; what Abseil accepts passes.
#include "common/flags/flag_precheck.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "absl/flags/flag.h"
#include "common/flags/flag_names.h"
#include "tests/support/server_process.h"

ABSL_FLAG(int, yy_workers, 1, "How many");
ABSL_FLAG(bool, yy_isolate, true, "A switch");
ABSL_FLAG(std::string, yy_name, "", "A name");

namespace impostor {
namespace {

// PrecheckFlags over `args` (argv[0] added), names underscored first as the
// daemons do.
absl::Status Check(std::vector<std::string> args) {
  args.insert(args.begin(), "prog");
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  UnderscoreFlagNames(static_cast<int>(argv.size()), argv.data());
  return PrecheckFlags(static_cast<int>(argv.size()), argv.data());
}

TEST(PrecheckFlags, WhatAbseilAcceptsPasses) {
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {},
           {"--yy-workers=3"},
           {"--yy_workers", "3"},
           {"-yy_workers=3"},
           {"--yy-isolate"},
           {"--noyy-isolate"},
           {"--yy-isolate=false"},
           {"--yy-name=", "positional"},
           {"--yy-name", "-looks-like-a-flag"},
           {"--", "--not-a-flag"},
           {"--only_check_args", "--undefok=yy_gone", "--yy_gone=1"},
       }) {
    EXPECT_TRUE(Check(args).ok()) << (args.empty() ? "" : args[0]) << ": " << Check(args).message();
  }
  EXPECT_EQ(absl::GetFlag(FLAGS_yy_name), "-looks-like-a-flag") << "the value was parsed as Abseil will parse it";
}

TEST(PrecheckFlags, WhatAbseilWouldExitOnIsRefusedNamingTheFlag) {
  const struct {
    std::vector<std::string> args;
    std::string message;
  } cases[] = {
      {{"--yy-workers=x"}, "--yy-workers: \"x\" is not a valid value"},
      {{"--yy-workers", "2x"}, "--yy-workers: \"2x\" is not a valid value"},
      {{"--yy-workers=99999999999999"}, "--yy-workers: \"99999999999999\" is not a valid value"},
      {{"--yy-workers"}, "--yy-workers needs a value"},
      {{"--noyy-workers"}, "--noyy-workers: --yy-workers is not a switch"},
      {{"--yy-isolate="}, "--yy-isolate= needs true or false"},
      {{"--yy-isolate=maybe"}, "--yy-isolate: \"maybe\" is not a valid value"},
      {{"--noyy-isolate=true"}, "--noyy-isolate takes no value"},
      {{"--yy-bogus=1"}, "unknown flag --yy-bogus (see --help)"},
      {{"-yy-bogus"}, "unknown flag -yy-bogus (see --help)"},
      {{"--=3"}, "\"--=3\" is not a flag"},
  };
  for (const auto& c : cases) {
    const absl::Status s = Check(c.args);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << c.args[0];
    EXPECT_NE(std::string(s.message()).find(c.message), std::string::npos) << c.args[0] << ": " << s.message();
  }
}

// The binaries: a flag Abseil cannot parse is exit 2 and one line, so
// systemd (RestartPreventExitStatus=2 4) and the local-worker supervisor do
// not restart a typo forever.
TEST(PrecheckFlags, DaemonsExitTwoOnFlagsAbseilCannotParse) {
  const std::string data = testing::NewTempDir("precheck_data").string();
  for (const char* binary : {"impostor-server", "impostor-worker"}) {
    for (const std::string flag : {"--log-level", "--no-such-flag=1", "--max-outage-seconds=soon"}) {
      if (std::string(binary) == "impostor-server" && flag == "--max-outage-seconds=soon") continue;
      const testing::ToolRun run = testing::RunTool(
          {(testing::BinaryDir() / binary).string(), "--listen=127.0.0.1:0", "--server=127.0.0.1:1",
           "--data=" + data, flag},
          std::chrono::seconds(60));
      EXPECT_EQ(run.exit_code, 2) << binary << " " << flag << "\n" << run.err;
      EXPECT_NE(run.err.find(std::string(binary) + ": "), std::string::npos) << run.err;
      EXPECT_EQ(run.err.find("ERROR:"), std::string::npos) << "Abseil's own refusal: " << run.err;
    }
  }
}

}  // namespace
}  // namespace impostor
