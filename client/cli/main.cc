// impostor: the command-line client of the impostor bake farm. Parses the
// command line and hands over to one subcommand (commands.h).
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "client/cli/cli_args.h"
#include "client/cli/commands.h"
#include "client/cli/output.h"

namespace {

// Diagnostics go to stderr (stdout may carry --json) and are off unless
// IMPOSTOR_LOG asks, so that a failure stays one line.
void SetUpLogging() {
  auto logger = spdlog::stderr_color_mt("impostor");
  spdlog::set_default_logger(logger);
  const char* level = std::getenv("IMPOSTOR_LOG");
  spdlog::set_level(level != nullptr ? spdlog::level::from_str(level) : spdlog::level::off);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace impostor::cli;
  SetUpLogging();
  const std::vector<std::string> args(argv + 1, argv + argc);
  absl::StatusOr<CliArgs> parsed = ParseCliArgs(args, std::getenv("IMPOSTOR_SERVER"));
  if (!parsed.ok()) {
    return Fail(kExitUsage, std::string(parsed.status().message()) + " (see 'impostor --help')");
  }
  switch (parsed->command) {
    case Command::kHelp:
      std::fputs(UsageText().c_str(), stdout);
      return kExitOk;
    case Command::kVersion:
      std::printf("impostor %s (baker %s)\n", IMPOSTOR_VERSION, IMPOSTOR_BAKER_VERSION);
      return kExitOk;
    case Command::kBake: return RunBake(*parsed);
    case Command::kBakeBatch: return RunBakeBatch(*parsed);
    case Command::kFetch: return RunFetch(*parsed);
    case Command::kQuality: return RunQuality(*parsed);
    case Command::kStatus: return RunStatus(*parsed);
    case Command::kCancel: return RunCancel(*parsed);
    case Command::kCacheGet: return RunCacheGet(*parsed);
    case Command::kCacheLs: return RunCacheLs(*parsed);
    case Command::kCacheGc: return RunCacheGc(*parsed);
  }
  return kExitUsage;
}
