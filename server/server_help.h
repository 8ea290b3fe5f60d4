// The --help text of impostor-server: its usage and how its flags are
// grouped. A flag is listed under the first group with a matching name
// prefix; one matching none is listed under "Other" (common/flags/flag_help.h), so
// a new flag always shows up, and belongs here only to get a better heading.
#ifndef IMPOSTOR_SERVER_SERVER_HELP_H_
#define IMPOSTOR_SERVER_SERVER_HELP_H_

#include "common/flags/flag_help.h"

namespace impostor {

inline ProgramHelp ServerHelp() {
  return {
      .program = "impostor-server",
      .usage = {"--data=DIR [--listen=HOST:PORT] [--local-workers=N] [flags]",
                "token create|list|revoke --data=DIR|--database=URL [--role=R] [--name=N]",
                "purge --worker=NAME --data=DIR"},
      .summary = "The bake farm's gRPC server: stores uploaded meshes and baked results (content-addressed, "
                 "under --data), queues bake jobs and leases them to impostor-worker processes, which it can "
                 "also start and supervise itself (--local-workers). Prints \"impostor-server listening on "
                 "HOST:PORT\" on stdout once serving; logs go to stderr. SIGTERM, SIGINT or SIGHUP drains and stops it. "
                 "`token` manages bearer tokens (README \"Securing a farm: tokens and roles\"); `purge` drops the "
                 "results a worker baked, offline.",
      .groups = {{"Listening", {"listen", "port_file", "http_", "tls_", "keepalive_"}},
                 {"Access control", {"auth", "token_"}},
                 {"Storage", {"data", "blob_dir", "store_", "max_blob_bytes", "partial_upload_", "result_touch_"}},
                 {"Jobs", {"lease_timeout_s", "max_attempts", "max_pending_", "job_retention_"}},
                 {"Workers", {"local_workers", "worker_", "retry_elsewhere_", "unplaceable_", "prefer_strong_", "pool"}},
                 {"Shutdown and logging", {"shutdown_", "log_"}}},
      .footer = "Exit status: 0 after a clean shutdown; 2, with one line on stderr, for an unknown flag or a "
                "value that does not parse, is out of range or is unusable (naming the flag and what it accepts), "
                "and for what stops it from starting: a data directory, database, certificate or address it cannot "
                "use.\nSee impostor-worker(1) and impostor(1).",
  };
}

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_SERVER_HELP_H_
