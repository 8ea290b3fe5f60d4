// Which of the server's RESOURCE_EXHAUSTED refusals of a SubmitBake pass
// with time, and what to wait for before sending the submit again: a quota
// is not a verdict on the asset (bake-batch holds the asset back, `bake`
// waits a while). Header-only and pure, so tests include it as is.
//
// The server names the quota in its error reason (common/error_reason.h);
// servers before the reasons said it only in their message
// (server/store/token_quotas.cc, server/scheduler/bake_scheduler_submit.cc), so without a reason
// these prefixes of that wording decide:
//   "pending jobs of token 'ci': 20 queued or running, the limit per token
//    is 20; retry once some finish"          -> kOwnJobs
//   "pending jobs of client \"ci\": 20, the limit per client is 20; ..."
//                                            -> kOwnJobs
//   "pending jobs: 5000 queued or running, the limit is 5000; retry later"
//                                            -> kBackoff (the farm's queue)
//   "bakes of token 'ci': 1000 in the last hour, the limit per token is
//    1000 per hour; retry later"             -> kBackoff (a sliding window)
// Everything else (the daily upload quota, a full disk, another code) is
// kNone: the refusal is the asset's result.
#ifndef IMPOSTOR_CLIENT_CLI_QUOTA_REFUSAL_H_
#define IMPOSTOR_CLIENT_CLI_QUOTA_REFUSAL_H_

#include <string_view>

#include "absl/status/status.h"
#include "common/error_reason.h"

namespace impostor::cli {

enum class QuotaWait {
  kNone,      // final: not a quota that frees up while the command runs
  kOwnJobs,   // frees up when jobs of this token or client finish
  kBackoff,   // frees up with time (a rate window, the farm's whole queue)
};

// `rpc`, `server_message` and `reason` as sdk::RpcErrorInfo carries them.
inline QuotaWait QuotaWaitFor(absl::StatusCode code, std::string_view rpc, std::string_view server_message,
                              std::string_view reason) {
  if (code != absl::StatusCode::kResourceExhausted || rpc != "SubmitBake") return QuotaWait::kNone;
  if (!reason.empty()) {
    if (reason == error_reason::kTokenPendingJobs || reason == error_reason::kClientPendingJobs) {
      return QuotaWait::kOwnJobs;
    }
    if (reason == error_reason::kFarmPendingJobs || reason == error_reason::kTokenBakesPerHour) {
      return QuotaWait::kBackoff;
    }
    return QuotaWait::kNone;  // a reason this client does not know: not one to wait for
  }
  auto starts_with = [&](std::string_view prefix) { return server_message.substr(0, prefix.size()) == prefix; };
  if (starts_with("pending jobs of token ") || starts_with("pending jobs of client ")) return QuotaWait::kOwnJobs;
  if (starts_with("pending jobs: ") || starts_with("bakes of token ")) return QuotaWait::kBackoff;
  return QuotaWait::kNone;
}

}  // namespace impostor::cli

#endif  // IMPOSTOR_CLIENT_CLI_QUOTA_REFUSAL_H_
