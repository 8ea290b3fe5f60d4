// When and how long to wait before trying a failed call again. Pure
// functions; thread-safe.
#ifndef IMPOSTOR_CLIENT_RETRY_H_
#define IMPOSTOR_CLIENT_RETRY_H_

#include <chrono>

#include "absl/status/status.h"

namespace impostor::sdk {

// UNAVAILABLE (server down, restarting, network blip) and DEADLINE_EXCEEDED
// are worth another try; every impostor.v1 RPC is idempotent, so retrying
// after a deadline cannot bake or upload twice.
bool IsRetryable(absl::StatusCode code);

// Delay before attempt `attempt` + 1 (attempt >= 1 is the one that failed):
// 100 ms doubled per attempt, capped at 5 s, with up to 20% jitter taken off
// so that many clients restarted together do not retry in lockstep.
std::chrono::milliseconds BackoffDelay(int attempt);

// Sleeps BackoffDelay(attempt).
void SleepBeforeRetry(int attempt);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_RETRY_H_
