// How every `impostor` command that talks to the server connects: the
// address, the client id, the outage budget (--max-outage-seconds, else the
// command's default) and the two lines on stderr when the server goes away
// and comes back.
#ifndef IMPOSTOR_CLIENT_CLI_CONNECTION_OPTIONS_H_
#define IMPOSTOR_CLIENT_CLI_CONNECTION_OPTIONS_H_

#include <string>

#include "client/cli/cli_args.h"
#include "impostor/cache.h"
#include "impostor/client.h"

namespace impostor::cli {

// ClientOptions for `args`: server, client id, max_outage_seconds
// (args.max_outage_seconds, else `default_outage_seconds`) and, unless
// --quiet, an on_connection_change that prints ConnectionLine to stderr.
sdk::ClientOptions ClientOptionsFor(const CliArgs& args, double default_outage_seconds);

// The same settings for a cache (server, outage budget, the lines).
void ApplyConnectionOptions(const CliArgs& args, double default_outage_seconds, sdk::CacheOptions* options);

// "impostor: lost server HOST (UNAVAILABLE: ...); retrying for up to 300 s"
// or "impostor: server HOST is back after 11.2 s", without a newline.
std::string ConnectionLine(const sdk::ConnectionEvent& event);

}  // namespace impostor::cli

#endif  // IMPOSTOR_CLIENT_CLI_CONNECTION_OPTIONS_H_
