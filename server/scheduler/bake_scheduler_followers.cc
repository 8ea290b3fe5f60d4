// Followers: jobs that asked for a key another job is already baking wait on that leader; when it
// ends they are settled with its result or its failure, and a leader nobody wants any more is
// cancelled.
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

using scheduler_internal::IsTerminal;

absl::Status BakeScheduler::RefreshLeasePriority(JobRecord& leader) {
  if (IsTerminal(leader.job.state()) || !leader.leader_job_id.empty()) return absl::OkStatus();
  int32_t best = INT32_MIN;
  if (!leader.requester_cancelled) best = leader.job.priority();
  auto followers = jobs_->ActiveFollowers(leader.job.job_id());
  if (!followers.ok()) return followers.status();
  for (const JobRecord& f : *followers) best = std::max(best, f.job.priority());
  // Nobody wants it any more: CancelBakeIfUnwanted decides its fate.
  if (best == INT32_MIN || best == leader.lease_priority) return absl::OkStatus();
  spdlog::info("event=priority_changed job={} from={} to={}", leader.job.job_id(), leader.lease_priority, best);
  leader.lease_priority = best;
  return Save(leader);
}

absl::Status BakeScheduler::SettleFollowers(const JobRecord& leader, const v1::Manifest* result) {
  if (!IsTerminal(leader.job.state())) return absl::OkStatus();
  auto followers = jobs_->ActiveFollowers(leader.job.job_id());
  if (!followers.ok()) return followers.status();
  for (JobRecord& f : *followers) {
    if (result != nullptr) {
      f.job.set_attempts(leader.job.attempts());
      CopyAttemptHistory(leader.job, f.job);
      ApplyResult(f, *result);
      if (auto s = Save(f); !s.ok()) return s;
      continue;
    }
    f.job.set_state(leader.job.state());
    f.job.set_progress(leader.job.progress());
    f.job.set_stage(leader.job.stage());
    f.job.set_attempts(leader.job.attempts());
    CopyAttemptHistory(leader.job, f.job);
    if (leader.job.has_error()) *f.job.mutable_error() = leader.job.error();
    if (auto s = Save(f); !s.ok()) return s;
  }
  return absl::OkStatus();
}

absl::Status BakeScheduler::SettleIfLeaderFinished(const std::string& leader_job_id) {
  auto leader = LoadJob(leader_job_id);
  if (!leader.ok()) return leader.status();
  if (!IsTerminal(leader->job.state())) return absl::OkStatus();
  std::optional<v1::Manifest> result;
  if (leader->job.state() == v1::JOB_STATE_SUCCEEDED) {
    auto intact = IntactResult(leader->job.cache_key());
    if (!intact.ok()) return intact.status();
    // Gone already (evicted, purged): left to the client's retry.
    if (!intact->has_value()) return absl::OkStatus();
    result = std::move(**intact);
  }
  spdlog::info("event=follower_settled_late leader={} state={}", leader_job_id, static_cast<int>(leader->job.state()));
  const absl::Status settled = SettleFollowers(*leader, result.has_value() ? &*result : nullptr);
  // Another server settled it first: its write won the row's version.
  return absl::IsAborted(settled) ? absl::OkStatus() : settled;
}

absl::Status BakeScheduler::CancelBakeIfUnwanted(JobRecord& leader) {
  if (IsTerminal(leader.job.state()) || !leader.requester_cancelled) return absl::OkStatus();
  auto followers = jobs_->ActiveFollowers(leader.job.job_id());
  if (!followers.ok()) return followers.status();
  if (!followers->empty()) return absl::OkStatus();
  CloseAttempt(leader.job, v1::JobAttempt::OUTCOME_CANCELLED, "cancelled by CancelJob", SharedNowMs());
  leader.job.set_state(v1::JOB_STATE_CANCELLED);
  leader.job.set_stage("cancelled");
  leader.job.mutable_error()->set_code(static_cast<int>(absl::StatusCode::kCancelled));
  leader.job.mutable_error()->set_message("cancelled by CancelJob");
  // The lease id stays so the worker's next report hears about the cancel.
  spdlog::info("event=bake_cancelled job={} cache_key={}", leader.job.job_id(), leader.job.cache_key());
  return Save(leader);
}

absl::StatusOr<int64_t> BakeScheduler::SweepFinishedJobs() {
  if (options_.job_retention_ms <= 0) return 0;
  const int64_t cutoff = SharedNowMs() - options_.job_retention_ms;
  constexpr int kBatch = 500;
  int64_t total = 0;
  {
    // One server on a shared database sweeps; the others skip.
    std::lock_guard lock(mu_);
    auto maintainer = jobs_->HoldMaintenanceLock();
    if (!maintainer.ok()) return maintainer.status();
    if (!*maintainer) return total;
  }
  for (;;) {
    // The lock is taken per batch: submits go on between batches.
    std::lock_guard lock(mu_);
    auto deleted = jobs_->DeleteFinishedJobsCreatedBefore(cutoff, kBatch);
    if (!deleted.ok()) return deleted.status();
    total += *deleted;
    if (*deleted < kBatch) break;
  }
  if (total > 0) spdlog::info("event=jobs_swept deleted={} created_before_ms={}", total, cutoff);
  return total;
}

}  // namespace impostor
