// impostor bake: upload, submit, watch, fetch.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <system_error>
#include <thread>

#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "client/cli/bake_settings.h"
#include "client/cli/commands.h"
#include "client/cli/connection_options.h"
#include "client/cli/flag_terms.h"
#include "client/cli/output.h"
#include "client/cli/progress_printer.h"
#include "client/cli/quality_command.h"
#include "client/cli/quota_refusal.h"
#include "impostor/client.h"

namespace impostor::cli {
namespace {

namespace fs = std::filesystem;

// Collects the --json report and prints it exactly once, whatever the outcome.
class BakeReport {
 public:
  BakeReport(const CliArgs& args) : args_(args), start_(std::chrono::steady_clock::now()) {
    json_ = BakeJson(args.target, args.out);
  }
  nlohmann::json& json() { return json_; }

  // `error` is the JSON's "CODE: message"; `line` the one stderr line
  // (default the same), which may say more ("bake failed: CODE: message").
  int Fail(int exit_code, const std::string& error, const std::string& line = "") {
    json_["error"] = error;
    json_["exit_code"] = exit_code;
    Print();
    return cli::Fail(exit_code, line.empty() ? error : line);
  }
  int Fail(int exit_code, const absl::Status& status) { return Fail(exit_code, Describe(status)); }
  // The bake itself failed (exit 1): "bake failed: CODE: message" on stderr.
  int BakeFailed(int code, const std::string& message) {
    const std::string error = CodeAndMessage(code, message);
    return Fail(kExitBakeFailed, error, absl::StrCat("bake failed: ", error));
  }
  int Succeed() {
    Print();
    return kExitOk;
  }

 private:
  void Print() {
    if (!args_.json) return;
    json_["wall_seconds"] =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    PrintJson(json_);
  }

  const CliArgs& args_;
  std::chrono::steady_clock::time_point start_;
  nlohmann::json json_;
};

// SubmitBake, sent again while the server refuses it for a quota that passes
// with time (quota_refusal.h), with a doubling backoff (1 s up to 30 s),
// for up to --max-outage-seconds; then that refusal. One line on stderr
// (unless --quiet) says the bake waits and why.
absl::StatusOr<sdk::SubmitResult> SubmitWaitingOutQuotas(sdk::Client& client, const CliArgs& args,
                                                         const sdk::BakeSettings& settings) {
  using Clock = std::chrono::steady_clock;
  const auto give_up_at = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
                                             args.max_outage_seconds.value_or(kBakeOutageSeconds)));
  double backoff_seconds = 1;
  bool announced = false;
  while (true) {
    absl::StatusOr<sdk::SubmitResult> submitted = client.SubmitBake(args.target, settings);
    if (submitted.ok()) return submitted;
    const std::optional<sdk::RpcErrorInfo> rpc = sdk::GetRpcErrorInfo(submitted.status());
    if (!rpc.has_value() ||
        QuotaWaitFor(submitted.status().code(), rpc->rpc, rpc->server_message, rpc->reason) == QuotaWait::kNone) {
      return submitted;
    }
    if (Clock::now() >= give_up_at) return submitted;
    const auto next_try = std::min(
        give_up_at,
        Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(backoff_seconds)));
    if (!args.quiet && !announced) {
      std::fprintf(stderr, "impostor: %s; waiting for the quota (up to %g s, see --max-outage-seconds)\n",
                   Describe(submitted.status()).c_str(), args.max_outage_seconds.value_or(kBakeOutageSeconds));
      announced = true;
    }
    // A backoff between attempts, not a synchronisation: nothing here can
    // tell when the server's quota frees up.
    std::this_thread::sleep_until(next_try);
    backoff_seconds = std::min(backoff_seconds * 2, 30.0);
  }
}

}  // namespace

int RunBake(const CliArgs& args) {
  if (args.targets.size() > 1) return RunBakeBatch(args);  // bake A B ...: a batch
  BakeReport report(args);
  const auto start = std::chrono::steady_clock::now();

  // Local problems first, so they are reported without needing a server.
  std::error_code ec;
  // (The JSON's codes as bake-batch gives them: NOT_FOUND, INTERNAL.)
  if (!fs::exists(args.target, ec)) {
    const std::string reason = absl::StrCat("model ", args.target, " not found");
    return report.Fail(kExitLocalIo, CodeAndMessage(static_cast<int>(absl::StatusCode::kNotFound), reason), reason);
  }
  fs::create_directories(args.out, ec);
  if (ec || !fs::is_directory(args.out)) {
    const std::string reason = absl::StrCat("cannot create output directory ", args.out, ": ",
                                            ec ? ec.message() : std::string("not a directory"));
    return report.Fail(kExitLocalIo, CodeAndMessage(static_cast<int>(absl::StatusCode::kInternal), reason), reason);
  }

  absl::StatusOr<std::unique_ptr<sdk::Client>> client =
      sdk::Client::Connect(ClientOptionsFor(args, kBakeOutageSeconds));
  if (!client.ok()) return report.Fail(kExitServer, client.status());

  const sdk::BakeSettings settings = BakeSettingsFromArgs(args);
  absl::StatusOr<sdk::SubmitResult> submitted = SubmitWaitingOutQuotas(**client, args, settings);
  if (!submitted.ok()) {
    const absl::Status& s = submitted.status();
    const std::optional<sdk::RpcErrorInfo> rpc = sdk::GetRpcErrorInfo(s);
    // The server judged the request itself (e.g. frames out of range): that
    // is the bake failing, not the transport.
    if (rpc.has_value() && rpc->rpc == "SubmitBake" && s.code() == absl::StatusCode::kInvalidArgument) {
      return report.BakeFailed(static_cast<int>(s.code()), InFlagTerms(rpc->server_message));
    }
    return report.Fail(ExitCodeFor(s), s);
  }
  report.json()["cache_key"] = submitted->cache_key;
  report.json()["job_id"] = submitted->job_id;
  report.json()["cached"] = submitted->cached;
  report.json()["uploaded_bytes"] = submitted->upload.bytes_uploaded;
  if (!args.quiet) {
    std::fprintf(stderr, "submitted %s: job %s, %d files, uploaded %d (%s)%s\n", args.target.c_str(),
                 submitted->job_id.c_str(), submitted->upload.files, submitted->upload.uploaded,
                 HumanBytes(submitted->upload.bytes_uploaded).c_str(), submitted->cached ? ", cached" : "");
  }

  if (submitted->cached && submitted->error_code != 0) {
    // A cached result that fails this request's quality gate.
    if (IsQualityGateFailure(submitted->error_code, submitted->error_message)) {
      FetchGatedResult(**client, submitted->cache_key, args.out, args.quiet, &report.json());
    }
    return report.BakeFailed(submitted->error_code, submitted->error_message);
  }
  if (!submitted->cached) {
    ProgressPrinter printer(stderr, isatty(STDERR_FILENO) == 1);
    absl::StatusOr<sdk::JobUpdate> final_state = (*client)->WatchJob(submitted->job_id, [&](const sdk::JobUpdate& u) {
      if (!args.quiet) printer.Update(u);
    });
    printer.Finish();
    if (!final_state.ok()) return report.Fail(ExitCodeFor(final_state.status()), final_state.status());
    report.json()["cached"] = final_state->cached;
    if (final_state->state == sdk::JobState::kFailed) {
      // The gate rejected a finished bake: its result is kept; fetch it.
      if (IsQualityGateFailure(final_state->error_code, final_state->error_message)) {
        FetchGatedResult(**client, submitted->cache_key, args.out, args.quiet, &report.json());
      }
      // (A failed job without a code: UNKNOWN, as bake-batch says.)
      return report.BakeFailed(final_state->error_code != 0 ? final_state->error_code
                                                            : static_cast<int>(absl::StatusCode::kUnknown),
                               final_state->error_message);
    }
    if (final_state->state == sdk::JobState::kCancelled) {
      std::string reason = "bake was cancelled";
      if (!final_state->error_message.empty()) absl::StrAppend(&reason, ": ", final_state->error_message);
      const int code = final_state->error_code != 0 ? final_state->error_code
                                                    : static_cast<int>(absl::StatusCode::kCancelled);
      return report.Fail(kExitBakeFailed, CodeAndMessage(code, reason), reason);
    }
    if (final_state->state != sdk::JobState::kSucceeded) {
      const std::string reason = absl::StrCat("job ", submitted->job_id, " ended in state ",
                                              std::string(sdk::JobStateName(final_state->state)));
      return report.Fail(kExitServer, CodeAndMessage(static_cast<int>(absl::StatusCode::kUnknown), reason), reason);
    }
  }

  absl::StatusOr<sdk::FetchResult> fetched = (*client)->Fetch(submitted->cache_key, args.out);
  if (!fetched.ok()) return report.Fail(ExitCodeFor(fetched.status()), fetched.status());
  ReportFetchedResult(*fetched, args.quiet, &report.json());

  if (!args.json) {
    std::printf("%s\n", fetched->manifest_path.string().c_str());
    for (const fs::path& f : fetched->files) {
      if (f != fetched->manifest_path) std::printf("%s\n", f.string().c_str());
    }
    std::fflush(stdout);
  }
  if (!args.quiet) {
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::fprintf(stderr, "baked %s -> %s (key %s%s), downloaded %s, %.1f s\n", args.target.c_str(),
                 args.out.c_str(), submitted->cache_key.c_str(), submitted->cached ? ", cached" : "",
                 HumanBytes(fetched->bytes_downloaded).c_str(), wall);
  }
  return report.Succeed();
}

}  // namespace impostor::cli
