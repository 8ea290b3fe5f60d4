// `impostor-server token create|list|revoke`: token management on the data
// directory, with the server running or stopped (tokens.sqlite3 is WAL; a
// running server sees a change within its validation TTL, 2 s).
#ifndef IMPOSTOR_SERVER_TOKEN_COMMAND_H_
#define IMPOSTOR_SERVER_TOKEN_COMMAND_H_

#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/token_store.h"

namespace impostor {

// args: everything after "token" (e.g. {"create", "--data", "D", ...}).
// Prints the secret (create) or the table (list) on stdout, errors on
// stderr. Exit code: 0 done, 1 refused by the store (name taken, no such
// token, database error), 2 bad command line.
int RunTokenCommand(const std::vector<std::string>& args);

// "90d", "12h", "30m", "45s" -> milliseconds; INVALID_ARGUMENT naming
// --expires-in otherwise (range 1 s .. 3650 d).
absl::StatusOr<int64_t> ParseExpiresIn(const std::string& text);

// The token --local-workers use: a fresh worker token named "local-workers"
// (the previous one is revoked), its secret written to
// DATA/local-workers.token readable by this user only. Returns that path.
absl::StatusOr<std::filesystem::path> MintLocalWorkerToken(TokenStore* store, const std::filesystem::path& data_dir);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_TOKEN_COMMAND_H_
