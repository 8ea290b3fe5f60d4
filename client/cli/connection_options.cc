#include "client/cli/connection_options.h"

#include <unistd.h>

#include <cstdio>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/cli/output.h"

namespace impostor::cli {
namespace {

// Prints one line per event. On a terminal the line first clears a live
// progress line, which the next update redraws.
std::function<void(const sdk::ConnectionEvent&)> PrintEvents(const CliArgs& args) {
  if (args.quiet) return nullptr;
  return [](const sdk::ConnectionEvent& event) {
    std::string line = ConnectionLine(event);
    for (char& c : line) {
      if (c == '\n' || c == '\r') c = ' ';
    }
    std::fprintf(stderr, "%s%s\n", isatty(STDERR_FILENO) == 1 ? "\r\033[K" : "", line.c_str());
    std::fflush(stderr);
  };
}

}  // namespace

sdk::ClientOptions ClientOptionsFor(const CliArgs& args, double default_outage_seconds) {
  sdk::ClientOptions options;
  options.server = args.server;
  options.client_id = args.client_id;
  options.token_file = args.token_file;
  options.farm_http = args.farm_http;
  options.max_outage_seconds = args.max_outage_seconds.value_or(default_outage_seconds);
  options.on_connection_change = PrintEvents(args);
  if (args.keepalive_seconds) options.keepalive_seconds = *args.keepalive_seconds;
  // Transport security (README "Securing a farm: TLS").
  options.tls_ca_file = args.tls_ca;
  options.tls_cert_file = args.tls_cert;
  options.tls_key_file = args.tls_key;
  options.tls_server_name = args.tls_server_name;
  return options;
}

void ApplyConnectionOptions(const CliArgs& args, double default_outage_seconds, sdk::CacheOptions* options) {
  options->server = args.server;
  options->token_file = args.token_file;
  options->farm_http = args.farm_http;
  options->max_outage_seconds = args.max_outage_seconds.value_or(default_outage_seconds);
  options->on_connection_change = PrintEvents(args);
  if (args.keepalive_seconds) options->keepalive_seconds = *args.keepalive_seconds;
  // Transport security (README "Securing a farm: TLS").
  options->tls_ca_file = args.tls_ca;
  options->tls_cert_file = args.tls_cert;
  options->tls_key_file = args.tls_key;
  options->tls_server_name = args.tls_server_name;
}

std::string ConnectionLine(const sdk::ConnectionEvent& event) {
  if (event.kind == sdk::ConnectionEvent::Kind::kRegained) {
    return absl::StrFormat("impostor: server %s is back after %.1f s", event.server, event.outage_seconds);
  }
  std::string line = absl::StrCat("impostor: lost server ", event.server, " (", Describe(event.error), ")");
  if (event.max_outage_seconds > 0) {
    absl::StrAppend(&line, absl::StrFormat("; retrying for up to %g s", event.max_outage_seconds));
  }
  return line;
}

}  // namespace impostor::cli
