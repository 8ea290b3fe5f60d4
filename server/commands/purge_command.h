// `impostor-server purge --worker NAME --data DIR`: the answer to a
// compromised worker (issue 14). Drops every result whose Manifest.baked_by
// is NAME, so their cache keys bake again on the next request; works with
// the server running (the job database is WAL and the server reads results
// from it on every request) or stopped. The blobs only those results used
// stay until the store cap evicts unreferenced blobs; readers can no longer
// read them (they belong to no result). This command cannot delete them
// safely beside a running server (uploads in progress, the server's store
// size); the admin RPC (`impostor admin purge`, AdminService) does both.
#ifndef IMPOSTOR_SERVER_COMMANDS_PURGE_COMMAND_H_
#define IMPOSTOR_SERVER_COMMANDS_PURGE_COMMAND_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/store/job_store.h"

namespace impostor {

// The cache keys of the results `worker` baked, now deleted.
absl::StatusOr<std::vector<std::string>> PurgeResultsBakedBy(JobStore& jobs, const std::string& worker);

// args: everything after "purge". Prints one line per purged key on stdout
// and a summary on stderr. Exit code: 0 done (also when nothing matched),
// 1 database error, 2 bad command line.
int RunPurgeCommand(const std::vector<std::string>& args);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_COMMANDS_PURGE_COMMAND_H_
