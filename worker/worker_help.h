// The --help text of impostor-worker: its usage and how its flags are
// grouped. A flag is listed under the first group with a matching name
// prefix; one matching none is listed under "Other" (common/flags/flag_help.h), so
// a new flag always shows up, and belongs here only to get a better heading.
#ifndef IMPOSTOR_WORKER_WORKER_HELP_H_
#define IMPOSTOR_WORKER_WORKER_HELP_H_

#include "common/flags/flag_help.h"

namespace impostor {

inline ProgramHelp WorkerHelp() {
  return {
      .program = "impostor-worker",
      .usage = {"[--server=HOST:PORT] [--device=NAME] [flags]"},
      .summary = "A bake worker: leases jobs from impostor-server, renders them with headless Vulkan (a GPU, or "
                 "lavapipe on the CPU when there is none) and uploads the results. Logs go to stderr; at start it "
                 "logs every Vulkan device it found and why it was or was not chosen. SIGTERM finishes or hands "
                 "back the current job and stops.",
      .groups = {{"Server connection", {"server", "tls_", "token_", "max_outage_seconds", "keepalive_", "name", "tags"}},
                 {"Rendering", {"device", "scratch"}},
                 {"Jobs", {"max_jobs", "heartbeat_s", "stall_s", "drain_seconds"}},
                 {"Input limits", {"max_triangles", "max_texture_dimension", "max_draws", "max_load_bytes",
                                   "isolate_load", "load_"}},
                 {"Logging", {"log_"}}},
      .footer = "Exit status: 0 after --max-jobs jobs or a drain, 1 when the server stayed unreachable for "
                "--max-outage-seconds, 2 for an unknown flag or a value that does not parse or is out of range (one "
                "line on stderr naming the flag) or an unreadable --token-file, 3 when no usable Vulkan device exists, "
                "4 when the server refused its token (unknown, revoked, expired, not a worker's).\n"
                "See impostor-server(1) and impostor(1).",
  };
}

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_WORKER_HELP_H_
