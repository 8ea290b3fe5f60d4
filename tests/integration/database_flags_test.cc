// impostor-server's PostgreSQL flags (issue 15): out-of-range values and a
// URL of another scheme are usage errors (exit 2, one line naming the flag
// and its range), refused before any database is contacted. The flags'
// effects are tested in tests/server (postgres_engine_test.cc,
// pg_dead_link_test.cc) and across namespaces (netns_multihost_test.cc).
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

TEST(DatabaseFlags, OutOfRangeValuesAreRefusedNamingTheFlag) {
  const std::filesystem::path data = NewTempDir("database_flags");
  // Nothing listens there: a flag that got past the checks would fail on
  // the connection instead, with another message.
  const std::string url = "--database=postgresql://farm:secret@127.0.0.1:1/farm";
  const struct {
    std::string flag;
    std::string message;
  } cases[] = {
      {"--database-dead-link-seconds=1", "--database-dead-link-seconds: 1 is out of range 2..3600 (seconds)"},
      {"--database-dead-link-seconds=3601", "--database-dead-link-seconds: 3601 is out of range 2..3600 (seconds)"},
      {"--database-dead-link-seconds=-20", "--database-dead-link-seconds: -20 is out of range 2..3600 (seconds)"},
      {"--database-maintenance-takeover-seconds=1",
       "--database-maintenance-takeover-seconds: 1 is out of range 2..3600"},
      {"--database-maintenance-takeover-seconds=3601",
       "--database-maintenance-takeover-seconds: 3601 is out of range 2..3600"},
      {"--database-pool-size=0", "--database-pool-size: 0 is out of range 1..64"},
      {"--database-pool-size=65", "--database-pool-size: 65 is out of range 1..64"},
      {"--database-statement-timeout-ms=99", "--database-statement-timeout-ms: 99 is out of range 100..600000"},
  };
  for (const auto& c : cases) {
    const ToolRun run = RunTool({(BinaryDir() / "impostor-server").string(), "--data=" + data.string(),
                                 "--listen=127.0.0.1:0", url, c.flag},
                                std::chrono::seconds(60));
    EXPECT_EQ(run.exit_code, 2) << c.flag;
    EXPECT_NE(run.err.find(c.message), std::string::npos) << c.flag << ": " << run.err;
    EXPECT_EQ(run.err.find("secret"), std::string::npos) << "the password stays out of errors: " << run.err;
  }
  // The same flags in range get as far as the database, and no further.
  const ToolRun reached = RunTool({(BinaryDir() / "impostor-server").string(), "--data=" + data.string(),
                                   "--listen=127.0.0.1:0", url, "--database-dead-link-seconds=2"},
                                  std::chrono::seconds(60));
  EXPECT_EQ(reached.exit_code, 2);
  EXPECT_NE(reached.err.find("--database: cannot connect to postgresql://farm:***@127.0.0.1:1/farm"),
            std::string::npos)
      << reached.err;
  std::filesystem::remove_all(data);
}

}  // namespace
}  // namespace impostor::testing
