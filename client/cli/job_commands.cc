// impostor status / impostor cancel: one unary call on a job.
#include <cstdio>
#include <functional>

#include "absl/strings/str_format.h"
#include "client/cli/commands.h"
#include "client/cli/connection_options.h"
#include "client/cli/output.h"
#include "client/cli/progress_printer.h"
#include "common/util/log_escape.h"
#include "impostor/client.h"

namespace impostor::cli {
namespace {

using JobCall = std::function<absl::StatusOr<sdk::JobUpdate>(sdk::Client&, const std::string&)>;

int RunJobCall(const CliArgs& args, const JobCall& call) {
  // --json: the job's object with every key (the job's fields null, not
  // known), `error` the {code, message} object a job's error is too, and
  // exit_code.
  auto fail = [&](int code, const absl::Status& status) {
    if (args.json) PrintJson(JobErrorJson(args.target, status, code));
    return Fail(code, Describe(status));
  };
  absl::StatusOr<std::unique_ptr<sdk::Client>> client =
      sdk::Client::Connect(ClientOptionsFor(args, kInteractiveOutageSeconds));
  if (!client.ok()) return fail(kExitServer, client.status());
  absl::StatusOr<sdk::JobUpdate> job = call(**client, args.target);
  if (!job.ok()) return fail(ExitCodeFor(job.status()), job.status());
  if (args.json) {
    PrintJson(JobToJson(*job));
    return kExitOk;
  }
  std::string line = absl::StrFormat("%s %s", job->job_id, ProgressPrinter::Format(*job));
  if (!job->cache_key.empty()) line += " key " + job->cache_key;
  if (job->cached) line += " (cached)";
  if (job->error_code != 0 || !job->error_message.empty()) {
    line += absl::StrFormat(" error %s: %s", absl::StatusCodeToString(static_cast<absl::StatusCode>(job->error_code)),
                            EscapeForTerminal(job->error_message, 4096));
  }
  std::printf("%s\n", line.c_str());
  return kExitOk;
}

}  // namespace

int RunStatus(const CliArgs& args) {
  return RunJobCall(args, [](sdk::Client& c, const std::string& id) { return c.GetJob(id); });
}

int RunCancel(const CliArgs& args) {
  return RunJobCall(args, [](sdk::Client& c, const std::string& id) { return c.CancelJob(id); });
}

}  // namespace impostor::cli
