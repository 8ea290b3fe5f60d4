// The `impostor` subcommands. Each returns the process exit code (see
// ExitCode in cli_args.h) and has printed its one failure line, if any.
#ifndef IMPOSTOR_CLIENT_CLI_COMMANDS_H_
#define IMPOSTOR_CLIENT_CLI_COMMANDS_H_

#include <filesystem>

#include "client/cli/cli_args.h"

namespace impostor::cli {

int RunBake(const CliArgs& args);
// impostor bake-batch SPEC, and impostor bake with several models
// (batch_command.cc).
int RunBakeBatch(const CliArgs& args);
int RunFetch(const CliArgs& args);
// impostor quality KEY (quality_command.cc).
int RunQuality(const CliArgs& args);
int RunStatus(const CliArgs& args);
int RunCancel(const CliArgs& args);
// impostor cache get / ls / gc (cache_commands.cc).
int RunCacheGet(const CliArgs& args);
int RunCacheLs(const CliArgs& args);
int RunCacheGc(const CliArgs& args);
// impostor admin purge (admin_command.cc).
int RunAdminPurge(const CliArgs& args);
// impostor publish, impostor catalog ls, and impostor fetch with --mirror
// (release_commands.cc; releases for game clients, issue 40).
int RunPublish(const CliArgs& args);
int RunCatalogLs(const CliArgs& args);
int RunFetchFromMirrors(const CliArgs& args);

// --cache-dir, else $IMPOSTOR_CACHE_DIR, else $XDG_CACHE_HOME/impostor, else
// ~/.cache/impostor (cache_commands.cc).
std::filesystem::path CacheDirFor(const CliArgs& args);

}  // namespace impostor::cli

#endif  // IMPOSTOR_CLIENT_CLI_COMMANDS_H_
