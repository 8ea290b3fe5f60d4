// BakeScheduler's read-only views for observers (the HTTP adapter and the
// metrics in server/http/ and server/metrics/) and its worker table. They
// read the same JobStore rows the scheduler writes, under the same mutex:
// the dashboard never keeps a second copy of the farm's state. While the
// job database is known to be down, the views answer UNAVAILABLE at once
// (JobStore::Outage) instead of queueing behind a reconnect.
#include <algorithm>
#include <chrono>
#include <set>
#include <thread>

#include "absl/strings/str_cat.h"
#include "common/util/sha256.h"
#include "server/scheduler/bake_scheduler.h"

namespace impostor {

absl::Status BakeScheduler::LockForView(std::unique_lock<std::mutex>& lock) {
  // Bounded, re-checking for an outage: another call may hold the lock for
  // as long as a hung database keeps it, and a dashboard or a scrape must
  // not wait that out (nor take the HTTP server's threads with it).
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::milliseconds(kViewLockWaitMs);
  while (!lock.try_lock()) {
    if (absl::Status down = jobs_->Outage(); !down.ok()) return down;
    if (std::chrono::steady_clock::now() >= give_up) {
      return absl::UnavailableError(absl::StrCat("the scheduler is busy: another call has held it for over ",
                                                 kViewLockWaitMs / 1000, " s (waiting on the job database?)"));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));  // polling a held lock, bounded above
  }
  return absl::OkStatus();
}

void BakeScheduler::SetObserver(SchedulerObserver* observer) {
  static SchedulerObserver none;
  std::lock_guard lock(mu_);
  observer_ = observer != nullptr ? observer : &none;
}

absl::StatusOr<std::map<v1::JobState, int64_t>> BakeScheduler::JobCountsByState() {
  std::unique_lock lock(mu_, std::defer_lock);
  if (absl::Status busy = LockForView(lock); !busy.ok()) return busy;
  auto counts = jobs_->CountByState();
  if (!counts.ok()) return counts.status();
  std::map<v1::JobState, int64_t> out;
  for (const auto& [state, n] : *counts) {
    if (v1::JobState_IsValid(state)) out[static_cast<v1::JobState>(state)] = n;
  }
  return out;
}

namespace {

BakeScheduler::JobListing Listing(const JobRecord& r, v1::Job view) {
  BakeScheduler::JobListing l;
  l.job = std::move(view);
  l.client_id = r.client_id;
  l.leader_job_id = r.leader_job_id;
  l.lease_priority = r.lease_priority;
  l.mesh = r.mesh;
  l.parameters = r.parameters;
  l.owner = r.owner;
  return l;
}

}  // namespace

absl::StatusOr<std::vector<BakeScheduler::JobListing>> BakeScheduler::ListJobs(
    v1::JobState state, int limit, const std::optional<JobStore::JobCursor>& after) {
  std::unique_lock lock(mu_, std::defer_lock);
  if (absl::Status busy = LockForView(lock); !busy.ok()) return busy;
  auto rows = jobs_->ListJobs(static_cast<int>(state), limit, after);
  if (!rows.ok()) return rows.status();
  std::vector<JobListing> out;
  out.reserve(rows->size());
  for (const JobRecord& r : *rows) {
    v1::Job view = View(r);
    view.clear_result();
    out.push_back(Listing(r, std::move(view)));
  }
  return out;
}

absl::StatusOr<BakeScheduler::JobListing> BakeScheduler::DescribeJob(const std::string& job_id) {
  std::unique_lock lock(mu_, std::defer_lock);
  if (absl::Status busy = LockForView(lock); !busy.ok()) return busy;
  auto r = LoadJob(job_id);
  if (!r.ok()) return r.status();
  return Listing(*r, View(*r));
}

absl::StatusOr<std::vector<JobStore::StoredResult>> BakeScheduler::ListResults(
    int limit, const std::optional<JobStore::ResultCursor>& after) {
  std::unique_lock lock(mu_, std::defer_lock);
  if (absl::Status busy = LockForView(lock); !busy.ok()) return busy;
  auto results = jobs_->ListResults(limit, after);
  if (!results.ok()) return results;
  // Uses noted in memory and not yet written (FlushResultTouches).
  for (auto& r : *results) r.last_used_ms = std::max(r.last_used_ms, UnwrittenUse(r.manifest.cache_key()));
  return results;
}

absl::StatusOr<JobStore::StoredResult> BakeScheduler::PeekResult(const std::string& cache_key) {
  if (!IsSha256Hex(cache_key)) {
    return absl::InvalidArgumentError(absl::StrCat("cache_key: expected 64 lowercase hex characters, got \"",
                                                   cache_key.substr(0, 80), "\""));
  }
  std::unique_lock lock(mu_, std::defer_lock);
  if (absl::Status busy = LockForView(lock); !busy.ok()) return busy;
  auto r = jobs_->GetStoredResult(cache_key);
  if (!r.ok()) return r.status();
  if (!r->has_value()) return absl::NotFoundError(absl::StrCat("cache_key: nothing baked under ", cache_key));
  auto job = jobs_->OldestJobWithKey(cache_key);
  if (!job.ok()) return job.status();
  (*r)->source_job_id = *job;
  (*r)->last_used_ms = std::max((*r)->last_used_ms, UnwrittenUse(cache_key));
  return std::move(**r);
}

void BakeScheduler::NoteWorkerSeen(const std::string& worker_id) {
  if (worker_id.empty()) return;
  const int64_t now = options_.now_ms();
  auto it = workers_.find(worker_id);
  if (it == workers_.end()) {
    // Bounded: forget the least recently seen worker that is not polling.
    if (workers_.size() >= kMaxTrackedWorkers) {
      auto oldest = workers_.end();
      for (auto w = workers_.begin(); w != workers_.end(); ++w) {
        if (w->second.polling == 0 && (oldest == workers_.end() || w->second.last_seen_ms < oldest->second.last_seen_ms)) {
          oldest = w;
        }
      }
      if (oldest == workers_.end()) return;
      workers_.erase(oldest);
    }
    it = workers_.emplace(worker_id, WorkerSeen{}).first;
  }
  it->second.last_seen_ms = now;
}

absl::StatusOr<std::vector<BakeScheduler::WorkerInfo>> BakeScheduler::Workers() {
  std::unique_lock lock(mu_, std::defer_lock);
  if (absl::Status busy = LockForView(lock); !busy.ok()) return busy;
  auto pending = jobs_->Pending();
  if (!pending.ok()) return pending.status();
  std::map<std::string, WorkerInfo> out;
  for (const auto& [id, seen] : workers_) {
    WorkerInfo& w = out[id];
    w.worker_id = id;
    w.device = seen.device;
    w.last_seen_ms = seen.last_seen_ms;
    w.capabilities = seen.capabilities;
  }
  for (const JobRecord& r : *pending) {
    if (r.job.state() != v1::JOB_STATE_RUNNING || !r.leader_job_id.empty() || r.worker_id.empty()) continue;
    WorkerInfo& w = out[r.worker_id];
    w.worker_id = r.worker_id;
    w.job_ids.push_back(r.job.job_id());
  }
  const int64_t now = options_.now_ms();
  std::vector<WorkerInfo> list;
  list.reserve(out.size());
  for (auto& [id, w] : out) {
    const auto seen = workers_.find(id);
    const bool polling = seen != workers_.end() && seen->second.polling > 0;
    if (auto s = streaks_.find(id); s != streaks_.end()) w.paused_until_ms = s->second.paused_until_ms;
    if (!w.job_ids.empty()) {
      w.state = WorkerStateName(0);
    } else if (IsPaused(id)) {
      w.state = WorkerStateName(1);
    } else if (polling || (w.last_seen_ms > 0 && now - w.last_seen_ms < options_.lease_timeout_ms)) {
      w.state = WorkerStateName(2);
    } else {
      w.state = WorkerStateName(3);
    }
    list.push_back(std::move(w));
  }
  return list;
}

absl::Status BakeScheduler::CheckReady() {
  if (stopping_) return absl::UnavailableError("shutting down");
  absl::Status probe = jobs_->Probe(kReadyProbeTimeoutMs);
  if (!probe.ok()) return absl::UnavailableError(absl::StrCat("job database: ", probe.message()));
  return absl::OkStatus();
}

}  // namespace impostor
