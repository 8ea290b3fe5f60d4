// impostor: the command-line client of the impostor bake farm. Parses the
// command line and hands over to one subcommand (commands.h).
#include <malloc.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "client/cli/cli_args.h"
#include "client/cli/commands.h"
#include "client/cli/output.h"
#include "common/net/grpc_log.h"
#include "common/net/tls_files.h"
#include "common/net/token_source.h"
#include "impostor/log.h"

namespace {

// The least SDK level the CLI's logger at `level` prints.
impostor::sdk::LogLevel SdkLevelFor(spdlog::level::level_enum level) {
  using impostor::sdk::LogLevel;
  switch (level) {
    case spdlog::level::trace:
    case spdlog::level::debug: return LogLevel::kDebug;
    case spdlog::level::info: return LogLevel::kInfo;
    case spdlog::level::warn: return LogLevel::kWarning;
    case spdlog::level::err:
    case spdlog::level::critical: return LogLevel::kError;  // (critical: the logger drops SDK errors)
    default: return LogLevel::kOff;
  }
}

// Diagnostics go to stderr (stdout may carry --json) and are off unless
// IMPOSTOR_LOG asks, so that a failure stays one line.
void SetUpLogging() {
  auto logger = spdlog::stderr_color_mt("impostor");
  spdlog::set_default_logger(logger);
  const char* level = std::getenv("IMPOSTOR_LOG");
  spdlog::set_level(level != nullptr ? spdlog::level::from_str(level) : spdlog::level::off);
  // The SDK logs through its own logger (impostor/log.h), not this one:
  // its lines join the CLI's, with the CLI's format and level.
  impostor::sdk::SetLogHandler(
      [](impostor::sdk::LogLevel sdk_level, std::string_view message) {
        static constexpr spdlog::level::level_enum kLevels[] = {spdlog::level::debug, spdlog::level::info,
                                                                spdlog::level::warn, spdlog::level::err};
        spdlog::default_logger_raw()->log(kLevels[static_cast<int>(sdk_level)], "{}", message);
      },
      SdkLevelFor(spdlog::get_level()));
  // gRPC's own log lines (e.g. "Handshake failed ..." for every TLS retry)
  // go to the same diagnostics, so that a failure stays the one line that
  // says why (the SDK puts gRPC's reason into it).
  impostor::RouteGrpcLogsToSpdlog();
}

// A download receives its bytes in 1 MiB messages. glibc serves each from
// fresh mmapped pages at first (and returns them on free), so a short-lived
// process spends its time zeroing pages: `impostor fetch` of a 67 MB result
// took 0.43 s with 8,500 page faults and 0.33 s with 4,500 once freed
// memory is kept for reuse (bench/fetch_bench.sh, one run each).
void KeepFreedMemoryForReuse() {
  mallopt(M_MMAP_THRESHOLD, 64 << 20);
  mallopt(M_TRIM_THRESHOLD, 256 << 20);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace impostor::cli;
  KeepFreedMemoryForReuse();
  SetUpLogging();
  const std::vector<std::string> args(argv + 1, argv + argc);
  absl::StatusOr<CliArgs> parsed = ParseCliArgs(args, std::getenv("IMPOSTOR_SERVER"));
  // A refused command line still gets its --json object (README: "on every
  // outcome").
  auto usage_error = [&](const std::string& reason) {
    if (nlohmann::json j = UsageErrorJson(args, reason); !j.is_null()) PrintJson(j);
    return Fail(kExitUsage, reason);
  };
  if (!parsed.ok()) return usage_error(std::string(parsed.status().message()) + " (see 'impostor --help')");
  // TLS files are read here so that a bad one is a usage error naming its
  // flag (the SDK would name its ClientOptions field).
  if (!parsed->tls_ca.empty()) {
    absl::StatusOr<impostor::ClientTlsPem> tls = impostor::ReadClientTlsFiles(
        {.ca = parsed->tls_ca, .cert = parsed->tls_cert, .key = parsed->tls_key},
        {.ca = "--tls-ca", .cert = "--tls-cert", .key = "--tls-key"});
    if (!tls.ok()) return usage_error(std::string(tls.status().message()));
  }
  // So is a token file (or $IMPOSTOR_TOKEN) that cannot be used: exit 2, not
  // the 3 of a farm that may come back.
  if (auto token = impostor::ResolveToken(parsed->token_file, "", std::getenv(impostor::kTokenEnvVar)); !token.ok()) {
    return usage_error(std::string(token.status().message()));
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
    case Command::kAdminPurge: return RunAdminPurge(*parsed);
    case Command::kPublish: return RunPublish(*parsed);
    case Command::kCatalogLs: return RunCatalogLs(*parsed);
  }
  return kExitUsage;
}
