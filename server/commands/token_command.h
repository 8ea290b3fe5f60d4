// `impostor-server token create|list|revoke`: token management on the data
// directory (--data) or the PostgreSQL database the replicas share
// (--database), with the servers running or stopped. A running server sees a
// new token at once and a revocation within its validation TTL
// (--token-cache-ttl-ms, default 2 s; authenticator.h).
#ifndef IMPOSTOR_SERVER_COMMANDS_TOKEN_COMMAND_H_
#define IMPOSTOR_SERVER_COMMANDS_TOKEN_COMMAND_H_

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/store/token_store.h"

namespace impostor {

// args: everything after "token" (e.g. {"create", "--data", "D", ...}).
// Prints the secret (create) or the table (list) on stdout, errors on
// stderr. Exit code: 0 done, 1 refused by the store (name taken, no such
// token, database error), 2 bad command line.
int RunTokenCommand(const std::vector<std::string>& args);

// "90d", "12h", "30m", "45s" -> milliseconds; INVALID_ARGUMENT naming
// --expires-in otherwise (range 1 s .. 3650 d).
absl::StatusOr<int64_t> ParseExpiresIn(const std::string& text);

// The name of the token a server's --local-workers use: "local-workers",
// or with a database several replicas share "local-workers-" and 12 hex
// digits of this host's name and `data_dir`, so that one replica's restart
// does not revoke another's local workers.
std::string LocalWorkerTokenName(bool shared_database, const std::filesystem::path& data_dir);

// The token --local-workers use: a fresh worker token named `name` (the
// previous one of that name is revoked), its secret written to
// DATA/local-workers.token readable by this user only. Returns that path.
absl::StatusOr<std::filesystem::path> MintLocalWorkerToken(TokenStore* store, const std::filesystem::path& data_dir,
                                                           const std::string& name);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_COMMANDS_TOKEN_COMMAND_H_
