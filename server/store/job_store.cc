#include "server/store/job_store.h"

#include <mutex>
#include <set>
#include <string>

#include <spdlog/spdlog.h>

#include "server/store/attempt_history.h"
#include "server/store/sqlite/sqlite_job_store.h"

namespace impostor {

static_assert(v1::JOB_STATE_CANCELLED == 5, "kShownStateSql names JOB_STATE_CANCELLED by number");

absl::StatusOr<std::unique_ptr<JobStore>> JobStore::Open(const std::filesystem::path& file) {
  auto store = SqliteJobStore::Open(file);
  if (!store.ok()) return store.status();
  return std::unique_ptr<JobStore>(std::move(*store));
}

void ApplyLeaseGrant(JobRecord& r, const LeaseGrant& grant) {
  r.job.set_state(v1::JOB_STATE_RUNNING);
  r.job.set_attempts(r.job.attempts() + 1);
  r.job.set_progress(0.0f);
  r.job.set_stage("leased");
  r.job.set_worker_id(grant.worker_id);
  r.job.set_updated_ms(grant.now_ms);
  r.lease_id = grant.lease_id;
  r.lease_deadline_ms = grant.lease_deadline_ms;
  r.worker_id = grant.worker_id;
  r.lease_holder = grant.lease_holder;
  OpenAttempt(r.job, grant.worker_id, grant.device, grant.now_ms);
}

bool SkipUnreadableJobRow(const absl::Status& why) {
  if (!absl::IsDataLoss(why)) return false;
  static std::mutex mu;
  static std::set<std::string> reported;
  std::lock_guard lock(mu);
  if (reported.size() < 1000 && reported.insert(std::string(why.message())).second) {
    spdlog::error("event=job_record_unreadable error=\"{}\" action=skipped", std::string(why.message()));
  }
  return true;
}

}  // namespace impostor
