// Lease expiry and dead workers: leases not renewed in time are lost and their jobs requeued, a
// worker's death or repeated failures hand its jobs back, and the expiry sweep is deferred while
// the store cannot vouch for the shared clock.
// (BakeScheduler is split by responsibility; bake_scheduler.h declares it.)
#include "server/scheduler/bake_scheduler.h"
#include "server/scheduler/manifest_stamp.h"

#include <openssl/rand.h>

#include <algorithm>
#include <array>
#include <climits>
#include <map>
#include <tuple>
#include <set>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "common/request/bake_request.h"
#include "common/error_reason.h"
#include "common/util/log_escape.h"
#include "common/request/quality_gate.h"
#include "common/util/sha256.h"
#include "common/util/utf8.h"
#include "server/store/attempt_history.h"
#include "server/store/database_full.h"
#include "server/scheduler/scheduler_internal.h"

namespace impostor {

using scheduler_internal::kStrandedLeadersPerSweep;

absl::StatusOr<int> BakeScheduler::ReleaseLeasesOfPreviousLocalWorkers() {
  if (jobs_->SharedWithOtherServers()) return 0;
  std::lock_guard lock(mu_);
  auto pending = jobs_->Pending();
  if (!pending.ok()) return pending.status();
  int released = 0;
  for (JobRecord& r : *pending) {
    if (r.job.state() != v1::JOB_STATE_RUNNING || r.lease_id.empty() || !r.worker_id.starts_with("local-")) continue;
    HandBack(r, "the server stopped and its local worker with it; queued again at the restart");
    spdlog::info("event=release job={} worker={} reason=\"server restarted\"", r.job.job_id(), r.worker_id);
    if (auto s = Save(r); !s.ok()) return s;
    ++released;
  }
  return released;
}

absl::Status BakeScheduler::LoseLease(JobRecord& r, std::string_view how) {
  const std::string worker = r.worker_id;
  const std::string stage = r.job.stage().empty() ? "leased" : r.job.stage();
  const std::string detail = how.empty() ? "" : absl::StrCat(", ", std::string(how));
  r.lease_id.clear();
  r.lease_deadline_ms = 0;
  ++r.lease_expiries;
  CloseAttempt(r.job, v1::JobAttempt::OUTCOME_LEASE_EXPIRED,
               how.empty() ? absl::StrCat("no report within the lease timeout of ", options_.lease_timeout_ms / 1000.0,
                                          " s at stage ", stage)
                           : how,
               SharedNowMs());
  NoteWorkerFailure(worker, r.job.job_id());
  if (r.job.attempts() >= options_.max_attempts) {
    r.job.set_state(v1::JOB_STATE_FAILED);
    r.job.set_stage("failed");
    // Every lease ended with a dead or hung worker: most likely the input
    // kills the baker (a poison job), so say that rather than "unavailable".
    r.job.mutable_error()->set_code(static_cast<int>(absl::StatusCode::kInternal));
    r.job.mutable_error()->set_message(
        static_cast<uint32_t>(r.lease_expiries) >= r.job.attempts()
            ? absl::StrCat("lease expired ", r.lease_expiries,
                           " times: the worker died or hung while baking it (last: worker ", worker, " at stage ",
                           stage, detail, ")")
            : absl::StrCat("failed after ", r.job.attempts(), " attempts; last error: lease expired: worker ", worker,
                           " died or hung at stage ", stage, detail));
  } else {
    r.job.set_state(v1::JOB_STATE_QUEUED);
    r.job.set_stage("queued");
  }
  spdlog::warn("event=lease_expired job={} worker=\"{}\" stage=\"{}\" attempts={} requeued={} how=\"{}\"",
               r.job.job_id(), EscapeUntrusted(worker), EscapeUntrusted(stage), r.job.attempts(), r.job.state() == v1::JOB_STATE_QUEUED,
               how.empty() ? std::string("stopped reporting") : std::string(how));
  observer_.load()->OnLeaseLost(worker, r.parameters.product());
  if (auto s = Save(r); !s.ok()) return s;
  return SettleFollowers(r);
}

absl::Status BakeScheduler::WorkerDied(const std::string& worker_id, const std::string& how) {
  std::lock_guard lock(mu_);
  auto running = jobs_->RunningOnWorker(worker_id);
  if (!running.ok()) return running.status();
  for (JobRecord& r : *running) {
    if (auto s = LoseLease(r, absl::StrCat("the process was ", how)); !s.ok()) return s;
  }
  return absl::OkStatus();
}

void BakeScheduler::NoteWorkerFailure(const std::string& worker_id, const std::string& job_id) {
  if (options_.worker_failure_limit <= 0 || worker_id.empty()) return;
  WorkerStreak& streak = streaks_[worker_id];
  if (std::find(streak.failed_jobs.begin(), streak.failed_jobs.end(), job_id) == streak.failed_jobs.end()) {
    streak.failed_jobs.push_back(job_id);
  }
  if (static_cast<int>(streak.failed_jobs.size()) < options_.worker_failure_limit) return;
  streak.paused_until_ms = options_.now_ms() + options_.worker_pause_ms;
  spdlog::warn("event=worker_paused worker=\"{}\" failed_jobs={} last_job={} pause_s={}", EscapeUntrusted(worker_id),
               streak.failed_jobs.size(), job_id, options_.worker_pause_ms / 1000);
  streak.failed_jobs.clear();
}

bool BakeScheduler::IsPaused(const std::string& worker_id) {
  auto it = streaks_.find(worker_id);
  return it != streaks_.end() && it->second.paused_until_ms > options_.now_ms();
}

bool BakeScheduler::WorkerPaused(const std::string& worker_id) {
  std::lock_guard lock(mu_);
  return IsPaused(worker_id);
}

int64_t BakeScheduler::SharedNowMs() const { return options_.now_ms() + jobs_->ClockOffsetMs(); }

bool BakeScheduler::LeaseExpiryDeferred() {
  // While the database was unreachable no worker's heartbeat could be
  // recorded, so every deadline that passed meanwhile says nothing about
  // the worker. Running leases get one lease timeout from when the database
  // answers again (as this sweep sees it: at worst later, never earlier) for
  // their workers' next heartbeats, rather than have their outage-length
  // added in the database: that would be one write per running job, by
  // whichever replicas noticed, and a replica that missed the outage would
  // add nothing. Local clock: the grace is a span on this server.
  const uint64_t recovered = jobs_->OutagesRecovered();
  const int64_t now = options_.now_ms();
  if (recovered != outages_seen_) {
    outages_seen_ = recovered;
    expiry_resumes_ms_ = now + options_.lease_timeout_ms;
    spdlog::info("event=lease_expiry_deferred reason=database_outage_ended resume_in_ms={}",
                 options_.lease_timeout_ms);
  }
  // The same while the database refuses writes for a full disk: heartbeats
  // and finished results wait in the workers (DATABASE_FULL) until one
  // lease timeout after the last refusal this server saw. Expiring them
  // meanwhile baked finished results again, or failed them for good.
  const uint64_t full = DatabaseFullRefusals().load(std::memory_order_relaxed);
  if (full != database_full_seen_) {
    database_full_seen_ = full;
    if (now >= expiry_resumes_ms_) {
      spdlog::warn("event=lease_expiry_deferred reason=database_full resume_in_ms={}", options_.lease_timeout_ms);
    }
    expiry_resumes_ms_ = std::max(expiry_resumes_ms_, now + options_.lease_timeout_ms);
  }
  return now < expiry_resumes_ms_;
}

absl::Status BakeScheduler::ExpireLeases() {
  std::lock_guard lock(mu_);
  // One server on a shared database sweeps; the others skip.
  auto maintainer = jobs_->HoldMaintenanceLock();
  if (!maintainer.ok()) return maintainer.status();
  // Every server notes ended outages, so one that takes the role over later
  // knows when its grace ran out.
  const bool deferred = LeaseExpiryDeferred();
  if (!*maintainer) return absl::OkStatus();
  absl::StatusOr<std::vector<JobRecord>> expired = std::vector<JobRecord>();
  if (!deferred) expired = jobs_->ExpiredLeases(SharedNowMs());
  if (!expired.ok()) return expired.status();
  for (JobRecord& r : *expired) {
    absl::Status s = LoseLease(r, "");
    // Another server finished or renewed it since the read: nothing lost.
    if (absl::IsAborted(s)) continue;
    if (!s.ok()) return s;
  }
  // Followers left waiting by a server that died while settling them.
  auto stranded = jobs_->FinishedLeadersWithWaitingFollowers(kStrandedLeadersPerSweep);
  if (!stranded.ok()) return stranded.status();
  for (const JobRecord& leader : *stranded) {
    if (auto s = SettleIfLeaderFinished(leader.job.job_id()); !s.ok()) return s;
  }
  return absl::OkStatus();
}

}  // namespace impostor
