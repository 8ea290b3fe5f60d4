// `--help` and `--version` of every binary, as people read them: each flag
// the binary defines is listed (dashed), each listed flag with its printed
// default is accepted by the binary, and no line shows a source path or
// Abseil's boilerplate.
//
// The server's and worker's flags are read from their sources (every
// ABSL_FLAG under server/ or worker/), independently of the registry the
// help text is generated from; the CLI's come from its parser's table.
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "client/cli/cli_args.h"
#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;

std::string Dashed(std::string name) {
  for (char& c : name) {
    if (c == '_') c = '-';
  }
  return name;
}

// Names of the ABSL_FLAGs defined in the sources under `dir`.
std::set<std::string> FlagsDefinedUnder(const fs::path& dir) {
  static const std::regex kFlag(R"(ABSL_FLAG\(\s*[^,]+,\s*([A-Za-z0-9_]+)\s*,)");
  std::set<std::string> names;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    const std::string ext = entry.path().extension().string();
    if (ext != ".cc" && ext != ".h") continue;
    std::ifstream in(entry.path());
    std::stringstream text;
    text << in.rdbuf();
    const std::string source = text.str();
    for (auto it = std::sregex_iterator(source.begin(), source.end(), kFlag); it != std::sregex_iterator(); ++it) {
      names.insert(Dashed((*it)[1]));
    }
  }
  return names;
}

// The flags of a --help text ("  --name=VALUE  help..." entries), each with
// its entry's text joined into one line.
std::map<std::string, std::string> ListedFlags(const std::string& help) {
  static const std::regex kEntry(R"(^  --([a-z0-9-]+)(=\S+)?( |$))");
  std::map<std::string, std::string> flags;
  std::istringstream in(help);
  std::string current;
  for (std::string line; std::getline(in, line);) {
    std::smatch m;
    if (std::regex_search(line, m, kEntry)) {
      current = m[1];
      flags[current] = line;
    } else if (!current.empty() && line.rfind("     ", 0) == 0) {
      flags[current] += " " + line.substr(line.find_first_not_of(' '));
    } else {
      current.clear();
    }
  }
  return flags;
}

void ExpectNoBoilerplate(const std::string& name, const std::string& help) {
  std::istringstream in(help);
  for (std::string line; std::getline(in, line);) {
    SCOPED_TRACE(name + ": " + line);
    EXPECT_EQ(line.find(IMPOSTOR_SOURCE_DIR), std::string::npos);
    // (A public header such as impostor/lod.h may be named; sources not.)
    EXPECT_FALSE(std::regex_search(line, std::regex(R"([A-Za-z0-9_]\.(cc|cpp)\b|/work/|/build/)")));
    EXPECT_EQ(line.find("absl"), std::string::npos);
    EXPECT_EQ(line.find("Flags from"), std::string::npos);
    EXPECT_LE(line.size(), 100u);
  }
}

struct AbslBinary {
  const char* name;
  const char* source_dir;  // where its ABSL_FLAGs are defined
};

class AbslBinaryHelpTest : public ::testing::TestWithParam<AbslBinary> {};

TEST_P(AbslBinaryHelpTest, ListsEveryDefinedFlagWithItsDefault) {
  const AbslBinary& binary = GetParam();
  const ToolRun help = RunTool({(BinaryDir() / binary.name).string(), "--help"});
  ASSERT_EQ(help.exit_code, 0) << help.err;
  EXPECT_EQ(help.out.rfind(std::string("Usage: ") + binary.name + " ", 0), 0u) << help.out;
  const std::map<std::string, std::string> listed = ListedFlags(help.out);
  const std::set<std::string> defined = FlagsDefinedUnder(fs::path(IMPOSTOR_SOURCE_DIR) / binary.source_dir);
  ASSERT_GE(defined.size(), 10u) << "the source scan found too few flags";
  for (const std::string& flag : defined) {
    ASSERT_TRUE(listed.contains(flag)) << binary.name << " --help does not list --" << flag << "\n" << help.out;
    EXPECT_TRUE(std::regex_search(listed.at(flag), std::regex(R"((Default: |\(default: ))"))) << listed.at(flag);
  }
  for (const char* general : {"help", "version", "flagfile"}) EXPECT_TRUE(listed.contains(general)) << general;
  ExpectNoBoilerplate(binary.name, help.out);
  // The -h, --helpfull and underscore spellings print the same text.
  for (const char* alias : {"-h", "--helpfull"}) {
    const ToolRun again = RunTool({(BinaryDir() / binary.name).string(), alias});
    EXPECT_EQ(again.exit_code, 0) << alias;
    EXPECT_EQ(again.out, help.out) << alias;
  }
}

TEST_P(AbslBinaryHelpTest, AcceptsEveryListedFlagAtItsPrintedDefault) {
  const AbslBinary& binary = GetParam();
  const ToolRun help = RunTool({(BinaryDir() / binary.name).string(), "--help"});
  ASSERT_EQ(help.exit_code, 0) << help.err;
  static const std::regex kDefault(R"((Default: |\(default: )(none|"[^"]*"|[^ ]+?)\.?( |$))");
  std::vector<std::string> argv = {(BinaryDir() / binary.name).string(), "--only_check_args"};
  for (const auto& [flag, entry] : ListedFlags(help.out)) {
    if (flag == "help" || flag == "version" || flag == "flagfile" || flag == "fromenv" || flag == "tryfromenv" ||
        flag == "undefok") {
      continue;
    }
    std::smatch m;
    ASSERT_TRUE(std::regex_search(entry, m, kDefault)) << "no default in: " << entry;
    // "(default: next to this binary)": the flag's own default is empty.
    std::string value = m[1] == "Default: " ? m[2].str() : "none";
    if (value == "none") value = "";
    if (value.size() >= 2 && value.front() == '"') value = value.substr(1, value.size() - 2);
    argv.push_back("--" + flag + "=" + value);
  }
  const ToolRun check = RunTool(argv);
  EXPECT_EQ(check.exit_code, 0) << check.out << check.err;
  // And an unknown one is refused: the check above can fail.
  argv.push_back("--no-such-flag=1");
  EXPECT_NE(RunTool(argv).exit_code, 0);
}

TEST_P(AbslBinaryHelpTest, VersionNamesTheVersionAndTheBakerVersion) {
  const AbslBinary& binary = GetParam();
  const ToolRun version = RunTool({(BinaryDir() / binary.name).string(), "--version"});
  EXPECT_EQ(version.exit_code, 0);
  EXPECT_EQ(version.out, std::string(binary.name) + " " IMPOSTOR_PROJECT_VERSION " (baker " IMPOSTOR_BAKER_VERSION ")\n");
}

INSTANTIATE_TEST_SUITE_P(Binaries, AbslBinaryHelpTest,
                         ::testing::Values(AbslBinary{"impostor-server", "server"},
                                           AbslBinary{"impostor-worker", "worker"}),
                         [](const auto& info) {
                           return std::string(info.param.name) == "impostor-server" ? "Server" : "Worker";
                         });

TEST(CliHelpTest, ListsEveryFlagOfEveryCommand) {
  const ToolRun help = RunTool({(BinaryDir() / "impostor").string(), "--help"});
  ASSERT_EQ(help.exit_code, 0) << help.err;
  EXPECT_EQ(help.out, cli::UsageText());
  EXPECT_NE(help.out.find("Usage"), std::string::npos) << help.out;
  const std::vector<std::string> flags = cli::AllFlags();
  ASSERT_GE(flags.size(), 20u);
  for (const std::string& flag : flags) {
    // As a word: "--out" must not be satisfied by "--out-dir".
    EXPECT_TRUE(std::regex_search(help.out, std::regex(flag + R"((?![a-z-]))")))
        << "impostor --help does not document " << flag;
  }
  ExpectNoBoilerplate("impostor", help.out);
}

TEST(CliHelpTest, VersionNamesTheVersionAndTheBakerVersion) {
  for (const char* spelling : {"--version", "version"}) {
    const ToolRun version = RunTool({(BinaryDir() / "impostor").string(), spelling});
    EXPECT_EQ(version.exit_code, 0) << spelling;
    EXPECT_EQ(version.out, "impostor " IMPOSTOR_PROJECT_VERSION " (baker " IMPOSTOR_BAKER_VERSION ")\n") << spelling;
  }
}

}  // namespace
}  // namespace impostor::testing
