// Which SubmitBake refusals bake-batch and bake wait out, and for what: the
// server's error reason (common/error_reason.h) and, from servers without
// reasons, its wording (server/store/token_quotas.cc, server/scheduler/bake_scheduler_submit.cc).
#include "client/cli/quota_refusal.h"

#include <string>

#include <gtest/gtest.h>

namespace impostor::cli {
namespace {

TEST(QuotaWaitFor, TellsOwnJobsFromBackoffFromFinalByTheServersWording) {
  using absl::StatusCode;
  const struct {
    const char* name;
    StatusCode code;
    const char* rpc;
    const char* message;
    QuotaWait want;
  } cases[] = {
      {"token pending jobs", StatusCode::kResourceExhausted, "SubmitBake",
       "pending jobs of token 'ci': 20 queued or running, the limit per token is 20; retry once some finish",
       QuotaWait::kOwnJobs},
      {"client pending jobs", StatusCode::kResourceExhausted, "SubmitBake",
       "pending jobs of client \"ci\": 20, the limit per client is 20; retry later", QuotaWait::kOwnJobs},
      {"farm queue", StatusCode::kResourceExhausted, "SubmitBake",
       "pending jobs: 5000 queued or running, the limit is 5000; retry later", QuotaWait::kBackoff},
      {"bakes per hour", StatusCode::kResourceExhausted, "SubmitBake",
       "bakes of token 'ci': 1000 in the last hour, the limit per token is 1000 per hour; retry later",
       QuotaWait::kBackoff},
      {"uploads per day", StatusCode::kResourceExhausted, "WriteBlob",
       "uploads of token 'ci': 5 bytes in the last 24 hours, the limit per token is 5 bytes per day",
       QuotaWait::kNone},
      {"full disk", StatusCode::kResourceExhausted, "SubmitBake", "write /var/lib/impostor/jobs: no space left",
       QuotaWait::kNone},
      {"another rpc", StatusCode::kResourceExhausted, "WatchJob", "pending jobs of token 'ci': 1", QuotaWait::kNone},
      {"another code", StatusCode::kUnavailable, "SubmitBake", "pending jobs of token 'ci': 1", QuotaWait::kNone},
  };
  for (const auto& c : cases) {
    EXPECT_EQ(QuotaWaitFor(c.code, c.rpc, c.message, ""), c.want) << c.name;
  }
}

TEST(QuotaWaitFor, TheErrorReasonDecidesOverTheWording) {
  using absl::StatusCode;
  const StatusCode kExhausted = StatusCode::kResourceExhausted;
  EXPECT_EQ(QuotaWaitFor(kExhausted, "SubmitBake", "reworded", "TOKEN_PENDING_JOBS"), QuotaWait::kOwnJobs);
  EXPECT_EQ(QuotaWaitFor(kExhausted, "SubmitBake", "reworded", "CLIENT_PENDING_JOBS"), QuotaWait::kOwnJobs);
  EXPECT_EQ(QuotaWaitFor(kExhausted, "SubmitBake", "reworded", "FARM_PENDING_JOBS"), QuotaWait::kBackoff);
  EXPECT_EQ(QuotaWaitFor(kExhausted, "SubmitBake", "reworded", "TOKEN_BAKES_PER_HOUR"), QuotaWait::kBackoff);
  // A reason wins over wording that says otherwise, and one this client
  // does not know is final rather than guessed at from the text.
  EXPECT_EQ(QuotaWaitFor(kExhausted, "SubmitBake", "pending jobs of token 'ci': 20", "TOKEN_BAKES_PER_HOUR"),
            QuotaWait::kBackoff);
  EXPECT_EQ(QuotaWaitFor(kExhausted, "SubmitBake", "pending jobs of token 'ci': 20", "SOMETHING_NEW"),
            QuotaWait::kNone);
  EXPECT_EQ(QuotaWaitFor(kExhausted, "UploadBlob", "", "TOKEN_UPLOAD_BYTES_PER_DAY"), QuotaWait::kNone);
  EXPECT_EQ(QuotaWaitFor(StatusCode::kUnavailable, "SubmitBake", "", "TOKEN_PENDING_JOBS"), QuotaWait::kNone);
}

}  // namespace
}  // namespace impostor::cli
