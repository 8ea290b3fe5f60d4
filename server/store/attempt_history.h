// The per-lease history of a job (Job.attempt_history, issue 16): one entry
// per lease, opened when a worker leases the job and closed with how the
// lease ended. Pure functions on a v1::Job, so the scheduler only calls them
// at each lease transition; the history travels inside the serialized Job,
// so no storage change is needed.
#ifndef IMPOSTOR_SERVER_STORE_ATTEMPT_HISTORY_H_
#define IMPOSTOR_SERVER_STORE_ATTEMPT_HISTORY_H_

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "impostor/v1/types.pb.h"

namespace impostor {

// Entries kept per job; older ones are dropped first and counted in
// Job.attempt_history_dropped. Releases do not count as attempts, so a job
// handed back again and again could otherwise grow without bound.
inline constexpr size_t kMaxAttemptHistory = 32;
// JobAttempt.message limit in bytes (longer messages are cut).
inline constexpr size_t kMaxAttemptMessageBytes = 512;

// Appends a RUNNING entry for the lease `job` just got (attempt =
// job.attempts()), dropping the oldest entry when over kMaxAttemptHistory.
void OpenAttempt(v1::Job& job, const std::string& worker_id, const std::string& device, int64_t now_ms);

// Closes the last entry if it is still RUNNING; a no-op otherwise (e.g. a
// worker's FailJob after CancelJob already closed it as CANCELLED).
void CloseAttempt(v1::Job& job, v1::JobAttempt::Outcome outcome, std::string_view message, int64_t now_ms);

// Gives a follower (`to`) the history of its leader's bake (`from`).
void CopyAttemptHistory(const v1::Job& from, v1::Job& to);

// "running", "succeeded", "failed", "lease_expired", "released",
// "cancelled" (the JSON API's spelling).
std::string AttemptOutcomeName(v1::JobAttempt::Outcome outcome);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_STORE_ATTEMPT_HISTORY_H_
