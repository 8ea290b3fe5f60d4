// How the `impostor` tool reports: the single failure line, the exit code a
// Status maps to, and JSON on stdout.
#ifndef IMPOSTOR_CLIENT_CLI_OUTPUT_H_
#define IMPOSTOR_CLIENT_CLI_OUTPUT_H_

#include <string>
#include <string_view>
#include <vector>

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
// "CODE: what: message": what happened to the asset or bake (e.g. "not
// submitted"), after the code as every JSON `error` string starts.
std::string Describe(const absl::Status& status, std::string_view what);
// "CODE: message" from a canonical code (a job's error_code) and a message.
std::string CodeAndMessage(int code, std::string_view message);

// True for the codes with which a server refuses a request for good: the
// same request gets the same answer until someone changes it or the farm
// (INVALID_ARGUMENT, NOT_FOUND, ALREADY_EXISTS, FAILED_PRECONDITION,
// OUT_OF_RANGE, UNAUTHENTICATED, PERMISSION_DENIED, UNIMPLEMENTED). The
// others (UNAVAILABLE, DEADLINE_EXCEEDED, RESOURCE_EXHAUSTED, ABORTED,
// INTERNAL, ...) may pass by themselves.
bool IsRefusal(absl::StatusCode code);

// kExitBakeFailed when the server refused the request (IsRefusal: e.g.
// NOT_FOUND, nothing under that key or job id; INVALID_ARGUMENT; no token, a
// bad one or one without the role), kExitServer for the other RPC failures
// (the farm down or failing, a quota: worth retrying) and corrupt downloads,
// kExitLocalIo for the rest (local files).
int ExitCodeFor(const absl::Status& status);

// Writes `json` as one line on stdout.
void PrintJson(const nlohmann::json& json);

// `status` and `cancel --json`: {job_id, cache_key, state, progress, stage,
// cached, error}, where error is null or {"code": "FAILED_PRECONDITION",
// "message": "..."}: the job's error. ErrorJson is the same object for an
// RPC that failed, so that `error` has one shape whatever went wrong.
nlohmann::json JobToJson(const sdk::JobUpdate& job);
nlohmann::json ErrorJson(const absl::Status& status);
// The same object when the call (or the command line) failed: every key,
// job_id as given (null when empty), the job's fields null (unknown),
// error ErrorJson(status), and exit_code.
nlohmann::json JobErrorJson(const std::string& job_id, const absl::Status& status, int exit_code);

// `admin purge --json` when it failed: {worker, cache_keys, blobs_removed,
// bytes_freed, blobs_kept, error, exit_code} with the results null
// (unknown), worker as given (null when empty), error "CODE: message".
nlohmann::json PurgeErrorJson(const std::string& worker, const std::string& error, int exit_code);

// `bake --json`'s object before anything happened: every key, `model` and
// `out_dir` as given (null when empty), error null and exit_code 0.
nlohmann::json BakeJson(const std::string& model, const std::string& out_dir);

// What `--json` prints when the command line itself is refused (exit 2), so
// that the JSON comes on every outcome: for bake-batch its summary (total 0),
// for bake, status, cancel and admin purge their object with every key
// (error "INVALID_ARGUMENT: <reason>", as {code, message} for status and
// cancel), for the others {"error", "exit_code"}. `args` is argv without
// argv[0]; null when it has no --json (before "--").
nlohmann::json UsageErrorJson(const std::vector<std::string>& args, const std::string& reason);

// Human-readable byte count, e.g. "12.3 MB".
std::string HumanBytes(int64_t bytes);

}  // namespace impostor::cli

#endif  // IMPOSTOR_CLIENT_CLI_OUTPUT_H_
