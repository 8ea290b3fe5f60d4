// `impostor cache get|ls|gc` against a real server: what they print and the
// exit codes they share with the rest of the CLI.
#include <algorithm>
#include <filesystem>

#include <gtest/gtest.h>

#include "tests/support/published_result.h"
#include "tests/support/server_process.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

struct CliCase {
  const char* name;
  std::vector<std::string> args;  // after "impostor"; --cache-dir and --server added where accepted
  int exit_code;
  // What stdout must say (exit 0), or the one "impostor: ..." line on
  // stderr (any other exit code).
  std::string mentions;
};

TEST(CacheCli, GetLsGcReportAndExitAsDocumented) {
  testing::ServerProcess server(0);
  const testing::PublishedResult published = testing::PublishResult(server, {100 << 10, 50 << 10, 20 << 10}, 50);
  const fs::path dir = testing::NewTempDir("cache_cli");
  const std::string key = published.key;
  const CliCase cases[] = {
      {"first get downloads", {"cache", "get", key, "--json"}, 0, "\"downloaded\":true"},
      {"second get is local", {"cache", "get", key, "--json"}, 0, "\"downloaded\":false"},
      {"plain get prints paths", {"cache", "get", key, "--quiet"}, 0, "albedo_alpha.png"},
      {"ls lists it", {"cache", "ls", "--json"}, 0, "\"cache_key\":\"" + key + "\""},
      {"gc under a large cap keeps it", {"cache", "gc", "--json"}, 0, "\"evicted_entries\":0"},
      {"gc to zero evicts it", {"cache", "gc", "--max-bytes", "0", "--json"}, 0, "\"evicted_entries\":1"},
      {"ls is empty after", {"cache", "ls"}, 0, "0 results"},
      {"malformed key", {"cache", "get", "xyz"}, 2,
       "impostor: INVALID_ARGUMENT: cache key \"xyz\": expected 64 lowercase hex characters"},
      {"never baked", {"cache", "get", std::string(64, 'd')}, 1, "impostor: NOT_FOUND: "},
      {"server unreachable", {"cache", "get", std::string(64, 'e'), "--server", "127.0.0.1:1"}, 3,
       "impostor: UNAVAILABLE: Connect (server 127.0.0.1:1)"},
      {"no verb", {"cache"}, 2, "impostor: 'cache' needs a subcommand: get, ls or gc"},
      {"unknown verb", {"cache", "frob"}, 2, "impostor: unknown command \"cache frob\""},
      {"ls takes no argument", {"cache", "ls", "extra"}, 2, "impostor: unexpected argument \"extra\" for 'cache ls'"},
      {"negative cap", {"cache", "gc", "--max-bytes", "-5"}, 2, "impostor: --max-bytes: expected a whole number"},
      {"get needs a key", {"cache", "get"}, 2, "impostor: 'cache get' needs KEY"},
  };
  for (const CliCase& c : cases) {
    std::vector<std::string> argv = {(testing::BinaryDir() / "impostor").string()};
    argv.insert(argv.end(), c.args.begin(), c.args.end());
    argv.push_back("--cache-dir");
    argv.push_back(dir.string());
    const bool takes_server = c.args.size() >= 2 && c.args[1] == "get";
    if (takes_server && std::find(argv.begin(), argv.end(), "--server") == argv.end()) {
      argv.push_back("--server");
      argv.push_back(server.address());
    }
    const testing::ToolRun run = testing::RunTool(argv);
    EXPECT_EQ(run.exit_code, c.exit_code) << c.name << "\nstdout: " << run.out << "\nstderr: " << run.err;
    const std::string& where = c.exit_code == 0 ? run.out : run.err;
    EXPECT_NE(where.find(c.mentions), std::string::npos)
        << c.name << (c.exit_code == 0 ? ": stdout: " : ": stderr: ") << where;
  }
}

// The C example (examples/c) downloads once, then answers from disk.
TEST(CApiExample, DownloadsOnceThenReadsFromDisk) {
  testing::ServerProcess server(0);
  const testing::PublishedResult published = testing::PublishResult(server, {100 << 10, 50 << 10, 20 << 10}, 51);
  const fs::path dir = testing::NewTempDir("c_example");
  const std::string example = (testing::BinaryDir() / "impostor_c_example").string();
  const char* expected[] = {"downloaded", "from disk"};
  for (const char* how : expected) {
    testing::ChildProcess run({example, server.address(), dir.string(), published.key});
    std::string out;
    ASSERT_EQ(run.Wait(&out), 0) << out;
    EXPECT_NE(out.find(published.key + ": " + how), std::string::npos) << out;
    EXPECT_NE(out.find("albedo map: " + (dir / "entries" / published.key / "albedo_alpha.png").string()),
              std::string::npos)
        << out;
  }
  const testing::ToolRun bad = testing::RunTool({example, server.address(), dir.string(), "nope"});
  EXPECT_EQ(bad.exit_code, 1) << bad.out << bad.err;
  EXPECT_NE(bad.out.find("get nope: INVALID_ARGUMENT: "), std::string::npos) << bad.out;
}

}  // namespace
}  // namespace impostor
