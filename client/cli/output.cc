#include "client/cli/output.h"

#include <cctype>
#include <cstdio>
#include <string_view>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/cli/batch_report.h"
#include "client/cli/cli_args.h"
#include "client/cli/flag_terms.h"
#include "common/util/log_escape.h"

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

std::string Describe(const absl::Status& status, std::string_view what) {
  std::string message(status.message());
  if (sdk::GetRpcErrorInfo(status).has_value()) message = InFlagTerms(message);
  return absl::StrCat(absl::StatusCodeToString(status.code()), ": ", std::string(what), ": ", message);
}

std::string CodeAndMessage(int code, std::string_view message) {
  return absl::StrCat(absl::StatusCodeToString(static_cast<absl::StatusCode>(code)), ": ", std::string(message));
}

bool IsRefusal(absl::StatusCode code) {
  switch (code) {
    case absl::StatusCode::kInvalidArgument:
    case absl::StatusCode::kNotFound:
    case absl::StatusCode::kAlreadyExists:
    case absl::StatusCode::kFailedPrecondition:
    case absl::StatusCode::kOutOfRange:
    case absl::StatusCode::kUnauthenticated:
    case absl::StatusCode::kPermissionDenied:
    case absl::StatusCode::kUnimplemented: return true;
    default: return false;
  }
}

int ExitCodeFor(const absl::Status& status) {
  if (sdk::GetRpcErrorInfo(status).has_value()) {
    // The server answered, and refused: CI retries exit 3, and a missing
    // token or role does not come back by itself.
    return IsRefusal(status.code()) ? kExitBakeFailed : kExitServer;
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
    // The object ErrorJson gives an RPC's error.
    j["error"] = {{"code", absl::StatusCodeToString(static_cast<absl::StatusCode>(job.error_code))},
                  {"message", job.error_message}};
  } else {
    j["error"] = nullptr;
  }
  return j;
}

nlohmann::json ErrorJson(const absl::Status& status) {
  std::string message(status.message());
  if (sdk::GetRpcErrorInfo(status).has_value()) message = InFlagTerms(message);
  return {{"code", absl::StatusCodeToString(status.code())}, {"message", message}};
}

nlohmann::json JobErrorJson(const std::string& job_id, const absl::Status& status, int exit_code) {
  return {{"job_id", job_id.empty() ? nlohmann::json(nullptr) : nlohmann::json(job_id)},
          {"cache_key", nullptr},
          {"state", nullptr},
          {"progress", nullptr},
          {"stage", nullptr},
          {"cached", nullptr},
          {"error", ErrorJson(status)},
          {"exit_code", exit_code}};
}

nlohmann::json PurgeErrorJson(const std::string& worker, const std::string& error, int exit_code) {
  return {{"worker", worker.empty() ? nlohmann::json(nullptr) : nlohmann::json(worker)},
          {"cache_keys", nullptr},
          {"blobs_removed", nullptr},
          {"bytes_freed", nullptr},
          {"blobs_kept", nullptr},
          {"error", error},
          {"exit_code", exit_code}};
}

nlohmann::json BakeJson(const std::string& model, const std::string& out_dir) {
  auto or_null = [](const std::string& s) { return s.empty() ? nlohmann::json(nullptr) : nlohmann::json(s); };
  return {{"model", or_null(model)}, {"cache_key", nullptr}, {"job_id", nullptr}, {"cached", false},
          {"out_dir", or_null(out_dir)}, {"manifest", nullptr},  {"files", nlohmann::json::array()},
          {"wall_seconds", 0.0},  {"uploaded_bytes", 0},  {"warnings", nlohmann::json::array()},
          {"quality", nullptr},   {"error", nullptr},     {"exit_code", 0}};
}

nlohmann::json UsageErrorJson(const std::vector<std::string>& args, const std::string& reason) {
  bool json = false;
  for (const std::string& a : args) {
    if (a == "--") break;
    if (a == "--json") json = true;
  }
  if (!json) return nullptr;
  const std::string command = args.empty() ? "" : args[0];
  if (command == "bake-batch") return SummaryJson(BatchCounts{}, 0.0, kExitUsage, reason);
  // The value of `flag` ("--out DIR" or "--out=DIR") before "--"; "" if none.
  auto flag_value = [&](const std::string& flag) {
    std::string value;
    for (size_t i = 1; i < args.size() && args[i] != "--"; ++i) {
      if (args[i] == flag && i + 1 < args.size()) value = args[i + 1];
      if (args[i].rfind(flag + "=", 0) == 0) value = args[i].substr(flag.size() + 1);
    }
    return value;
  };
  // The first argument when it is not a flag (MODEL, JOB_ID).
  const std::string first = args.size() > 1 && args[1].rfind("-", 0) != 0 ? args[1] : "";
  if (command == "status" || command == "cancel") {
    return JobErrorJson(first, absl::InvalidArgumentError(reason), kExitUsage);
  }
  if (command == "admin" && args.size() > 1 && args[1] == "purge") {
    return PurgeErrorJson(flag_value("--worker"), absl::StrCat("INVALID_ARGUMENT: ", reason), kExitUsage);
  }
  nlohmann::json j = {{"error", absl::StrCat("INVALID_ARGUMENT: ", reason)}, {"exit_code", kExitUsage}};
  if (command == "bake") {
    // MODEL as in the usual `bake MODEL ...` and --out DIR, when given;
    // null otherwise (the command line could not be read).
    j = BakeJson(first, flag_value("--out"));
    j["error"] = absl::StrCat("INVALID_ARGUMENT: ", reason);
    j["exit_code"] = kExitUsage;
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
