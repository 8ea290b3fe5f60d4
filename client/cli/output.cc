#include "client/cli/output.h"

#include <cctype>
#include <cstdio>
#include <string_view>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/cli/cli_args.h"
#include "client/cli/flag_terms.h"
#include "common/log_escape.h"

namespace impostor::cli {

int Fail(int exit_code, std::string_view reason) {
  // Reasons carry server and worker text: no control sequences reach the
  // terminal, and a runaway message is cut.
  const std::string line = EscapeForTerminal(reason, 4096);
  std::fprintf(stderr, "impostor: %s\n", line.c_str());
  std::fflush(stderr);
  return exit_code;
}

std::string Describe(const absl::Status& status) {
  std::string message(status.message());
  // Only what the server said about a request is in API terms.
  if (sdk::GetRpcErrorInfo(status).has_value()) message = InFlagTerms(message);
  return absl::StrCat(absl::StatusCodeToString(status.code()), ": ", message);
}

int ExitCodeFor(const absl::Status& status) {
  if (sdk::GetRpcErrorInfo(status).has_value()) {
    // The server answered, and refused: nothing under that key or job id,
    // or a request it judged invalid. CI retries exit 3, not these.
    if (status.code() == absl::StatusCode::kNotFound || status.code() == absl::StatusCode::kInvalidArgument) {
      return kExitBakeFailed;
    }
    return kExitServer;
  }
  if (status.code() == absl::StatusCode::kDataLoss) return kExitServer;
  return kExitLocalIo;
}

void PrintJson(const nlohmann::json& json) {
  // Invalid UTF-8 in a path must not abort the dump: replace it.
  const std::string text = json.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  std::fprintf(stdout, "%s\n", text.c_str());
  std::fflush(stdout);
}

nlohmann::json JobToJson(const sdk::JobUpdate& job) {
  nlohmann::json j = {
      {"job_id", job.job_id},
      {"cache_key", job.cache_key},
      {"state", std::string(sdk::JobStateName(job.state))},
      {"progress", job.progress},
      {"stage", job.stage},
      {"cached", job.cached},
  };
  if (job.error_code != 0 || !job.error_message.empty()) {
    j["error"] = {{"code", absl::StatusCodeToString(static_cast<absl::StatusCode>(job.error_code))},
                  {"message", job.error_message}};
  } else {
    j["error"] = nullptr;
  }
  return j;
}

std::string HumanBytes(int64_t bytes) {
  if (bytes < 1024) return absl::StrCat(bytes, " B");
  if (bytes < (1 << 20)) return absl::StrFormat("%.1f KiB", static_cast<double>(bytes) / 1024);
  if (bytes < (int64_t{1} << 30)) return absl::StrFormat("%.1f MiB", static_cast<double>(bytes) / (1 << 20));
  return absl::StrFormat("%.2f GiB", static_cast<double>(bytes) / (int64_t{1} << 30));
}

}  // namespace impostor::cli
