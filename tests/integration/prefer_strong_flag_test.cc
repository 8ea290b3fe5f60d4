// impostor-server --prefer-strong-seconds (issue 44): an out-of-range value
// is a usage error (exit 2, one line naming the flag and its range). What
// the bound does is tested in tests/server/strong_worker_preference_test.cc
// with a fake clock.
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

TEST(PreferStrongFlag, AnOutOfRangeBoundIsRefusedNamingTheFlagAndItsRange) {
  const std::filesystem::path data = NewTempDir("prefer_strong_flag");
  const struct {
    std::string flag;
    std::string message;
  } cases[] = {
      {"--prefer-strong-seconds=-1", "--prefer-strong-seconds: -1 is out of range 0..3600"},
      {"--prefer-strong-seconds=3601", "--prefer-strong-seconds: 3601 is out of range 0..3600"},
  };
  for (const auto& c : cases) {
    const ToolRun run = RunTool({(BinaryDir() / "impostor-server").string(), "--data=" + data.string(),
                                 "--listen=127.0.0.1:0", c.flag},
                                std::chrono::seconds(60));
    EXPECT_EQ(run.exit_code, 2) << c.flag;
    EXPECT_NE(run.err.find(c.message), std::string::npos) << c.flag << ": " << run.err;
  }
  std::filesystem::remove_all(data);
}

}  // namespace
}  // namespace impostor::testing
