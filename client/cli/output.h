// How the `impostor` tool reports: the single failure line, the exit code a
// Status maps to, and JSON on stdout.
#ifndef IMPOSTOR_CLIENT_CLI_OUTPUT_H_
#define IMPOSTOR_CLIENT_CLI_OUTPUT_H_

#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "absl/status/status.h"
#include "impostor/client.h"

namespace impostor::cli {

// Prints "impostor: <reason>" as one line on stderr (newlines in `reason`
// become spaces) and returns `exit_code`.
int Fail(int exit_code, std::string_view reason);

// "CODE: message", without the payloads absl::Status::ToString would add.
// A message from the server names API fields (parameters.ring_views) and
// enum values (PRODUCT_CARDS); these read as the flags and words the user
// typed ("--ring (parameters.ring_views)", "cards").
std::string Describe(const absl::Status& status);

// kExitBakeFailed when the server refused the request (NOT_FOUND: nothing
// under that key or job id; INVALID_ARGUMENT), kExitServer for the other RPC
// failures (the farm down or failing) and corrupt downloads, kExitLocalIo for
// the rest (local files).
int ExitCodeFor(const absl::Status& status);

// Writes `json` as one line on stdout.
void PrintJson(const nlohmann::json& json);

nlohmann::json JobToJson(const sdk::JobUpdate& job);

// Human-readable byte count, e.g. "12.3 MB".
std::string HumanBytes(int64_t bytes);

}  // namespace impostor::cli

#endif  // IMPOSTOR_CLIENT_CLI_OUTPUT_H_
