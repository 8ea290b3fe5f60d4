// `impostor cache get|ls|gc` against a real server: what they print and the
// exit codes they share with the rest of the CLI.
#include <algorithm>
#include <filesystem>

#include <gtest/gtest.h>

#include "tests/cache/published_result.h"
#include "tests/integration/server_process.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

struct CliCase {
  const char* name;
  std::vector<std::string> args;  // after "impostor"; --cache-dir and --server added where accepted
  int exit_code;
  std::string stdout_mentions;
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
      {"malformed key", {"cache", "get", "xyz"}, 2, ""},
      {"never baked", {"cache", "get", std::string(64, 'd')}, 3, ""},
      {"server unreachable", {"cache", "get", std::string(64, 'e'), "--server", "127.0.0.1:1"}, 3, ""},
      {"no verb", {"cache"}, 2, ""},
      {"unknown verb", {"cache", "frob"}, 2, ""},
      {"ls takes no argument", {"cache", "ls", "extra"}, 2, ""},
      {"negative cap", {"cache", "gc", "--max-bytes", "-5"}, 2, ""},
      {"get needs a key", {"cache", "get"}, 2, ""},
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
    testing::ChildProcess cli(argv);
    std::string stdout_text;
    EXPECT_EQ(cli.Wait(&stdout_text), c.exit_code) << c.name << ": " << stdout_text;
    EXPECT_NE(stdout_text.find(c.stdout_mentions), std::string::npos) << c.name << ": " << stdout_text;
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
  testing::ChildProcess bad({example, server.address(), dir.string(), "nope"});
  std::string out;
  EXPECT_EQ(bad.Wait(&out), 1);
  EXPECT_NE(out.find("INVALID_ARGUMENT"), std::string::npos) << out;
}

}  // namespace
}  // namespace impostor
