// Pools and shares (issue 44): which team a pool's worker serves first
// (pool_shares.h holds the rule), and the pools as the dashboard shows
// them. (BakeScheduler is split by responsibility; bake_scheduler.h
// declares it.)
#include <algorithm>

#include <spdlog/spdlog.h>

#include "common/util/log_escape.h"
#include "server/scheduler/bake_scheduler.h"

namespace impostor {

bool BakeScheduler::InPool(const WorkerPool& pool, const std::string& worker_id) const {
  const auto w = workers_.find(worker_id);
  if (w == workers_.end() || !w->second.capabilities) return false;
  const auto& tags = w->second.capabilities->tags();
  return std::find(tags.begin(), tags.end(), pool.tag) != tags.end();
}

int64_t BakeScheduler::PoolWorkersAbout(const WorkerPool& pool) {
  int64_t n = 0;
  for (const auto& [id, seen] : workers_) {
    if (IsAbout(seen) && InPool(pool, id) && !IsPaused(id)) ++n;
  }
  return n;
}

std::map<std::string, int64_t> BakeScheduler::RunningPerTeamInPool(
    const WorkerPool& pool, const std::vector<JobStore::RunningLease>& running) const {
  std::map<std::string, int64_t> per_team;
  for (const JobStore::RunningLease& lease : running) {
    if (!InPool(pool, lease.worker_id)) continue;
    for (const TeamShare& share : pool.shares) {
      if (JobOfTeam(lease.owner, lease.client_id, share.team)) ++per_team[share.team];
    }
  }
  return per_team;
}

absl::Status BakeScheduler::PreferOwedTeams(std::vector<JobRecord>& heads, const std::string& worker_id,
                                            const std::vector<std::string>& skipped) {
  if (options_.pools.empty() || heads.empty()) return absl::OkStatus();
  std::optional<std::vector<JobStore::RunningLease>> running;  // read once, when a pool has shares
  for (const WorkerPool& pool : options_.pools) {
    if (pool.shares.empty() || !InPool(pool, worker_id)) continue;
    if (!running) {
      auto got = jobs_->RunningLeases();
      if (!got.ok()) return got.status();
      running = std::move(*got);
    }
    for (const std::string& team : OwedTeams(pool, PoolWorkersAbout(pool), RunningPerTeamInPool(pool, *running))) {
      const auto first = std::find_if(heads.begin(), heads.end(), [&](const JobRecord& r) {
        return JobOfTeam(r.owner, r.client_id, team);
      });
      if (first != heads.end()) {
        if (first != heads.begin()) {
          spdlog::debug("event=pool_share job={} worker=\"{}\" pool={} team=\"{}\"", first->job.job_id(),
                        EscapeUntrusted(worker_id), pool.name, EscapeUntrusted(team));
        }
        std::rotate(heads.begin(), first, first + 1);
        return absl::OkStatus();
      }
      // None at the queue's highest priority: the team's own best job, if
      // this worker may take it.
      auto queued = jobs_->QueuedOfTeam(team, kOwedTeamLookahead);
      if (!queued.ok()) return queued.status();
      const int64_t now = SharedNowMs();
      for (JobRecord& r : *queued) {
        if (std::find(skipped.begin(), skipped.end(), r.job.job_id()) != skipped.end()) continue;
        if (!FitsWorker(r, worker_id) || !StrongerWorkerFor(r, worker_id, now).empty() ||
            FailedLatelyBy(r, worker_id, now)) {
          continue;
        }
        spdlog::debug("event=pool_share job={} worker=\"{}\" pool={} team=\"{}\" priority={}", r.job.job_id(),
                      EscapeUntrusted(worker_id), pool.name, EscapeUntrusted(team), r.lease_priority);
        heads.insert(heads.begin(), std::move(r));
        return absl::OkStatus();
      }
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<std::vector<BakeScheduler::PoolInfo>> BakeScheduler::Pools() {
  if (options_.pools.empty()) return std::vector<PoolInfo>();
  std::unique_lock lock(mu_, std::defer_lock);
  if (absl::Status busy = LockForView(lock); !busy.ok()) return busy;
  auto running = jobs_->RunningLeases();
  if (!running.ok()) return running.status();
  std::vector<PoolInfo> out;
  for (const WorkerPool& pool : options_.pools) {
    PoolInfo info;
    info.name = pool.name;
    info.tag = pool.tag;
    info.workers = PoolWorkersAbout(pool);
    for (const JobStore::RunningLease& lease : *running) {
      if (InPool(pool, lease.worker_id)) ++info.running;
    }
    const auto per_team = RunningPerTeamInPool(pool, *running);
    for (const TeamShare& share : pool.shares) {
      const auto it = per_team.find(share.team);
      info.shares.push_back({.team = share.team,
                             .percent = share.percent,
                             .guaranteed = GuaranteedWorkers(share.percent, info.workers),
                             .running = it == per_team.end() ? 0 : it->second});
    }
    out.push_back(std::move(info));
  }
  return out;
}

}  // namespace impostor
