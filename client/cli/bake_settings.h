// The bake settings a command line asks for: one mapping from flags to
// sdk::BakeSettings, shared by `impostor bake MODEL` and the batch forms
// (`bake A B ...`, whose every model takes the flags' settings).
#ifndef IMPOSTOR_CLIENT_CLI_BAKE_SETTINGS_H_
#define IMPOSTOR_CLIENT_CLI_BAKE_SETTINGS_H_

#include "client/cli/cli_args.h"
#include "impostor/client.h"

namespace impostor::cli {

sdk::BakeSettings BakeSettingsFromArgs(const CliArgs& args);

}  // namespace impostor::cli

#endif  // IMPOSTOR_CLIENT_CLI_BAKE_SETTINGS_H_
