// The scheduler's core: construction, job records saved and read, the change
// counter watchers wait on, shutdown, and owner queries. The rest of
// BakeScheduler lives beside it by responsibility: _submit, _results,
// _followers, _leases, _expiry, _views and _purge.
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
namespace {

SchedulerObserver* NoObserver() {
  static SchedulerObserver none;
  return &none;
}

}  // namespace

using scheduler_internal::IsTerminal;
using scheduler_internal::SystemNowMs;

std::string NewId(std::string_view prefix) {
  std::array<unsigned char, 16> bytes{};
  RAND_bytes(bytes.data(), static_cast<int>(bytes.size()));
  static constexpr char kHex[] = "0123456789abcdef";
  std::string id(prefix);
  for (unsigned char b : bytes) {
    id.push_back(kHex[b >> 4]);
    id.push_back(kHex[b & 0xf]);
  }
  return id;
}

BakeScheduler::BakeScheduler(JobStore* jobs, BlobStore* blobs, SchedulerOptions options)
    : jobs_(jobs), blobs_(blobs), options_([&] {
        if (!options.now_ms) options.now_ms = SystemNowMs;
        return options;
      }()),
      hot_results_(jobs->SharedWithOtherServers() ? 0 : options.hot_result_entries),
      outages_seen_(jobs->OutagesRecovered()),
      database_full_seen_(DatabaseFullRefusals().load()),
      observer_(NoObserver()) {
  // Jobs other servers change on a shared database wake our waiters too.
  jobs_->SetChangeCallback([this] {
    std::lock_guard lock(mu_);
    ++changes_;
    changed_.notify_all();
  });
}

absl::Status BakeScheduler::Save(JobRecord& record) {
  record.job.set_updated_ms(SharedNowMs());
  if (auto s = jobs_->Update(record); !s.ok()) return s;
  ++record.row_version;
  ++changes_;
  changed_.notify_all();
  return absl::OkStatus();
}

BakeScheduler::~BakeScheduler() {
  // Before the lock: the store waits for a running callback, which may take it.
  jobs_->SetChangeCallback(nullptr);
  std::lock_guard lock(mu_);
  if (auto s = FlushTouchesLocked(); !s.ok()) {
    spdlog::warn("event=touch_results_failed error=\"{}\"", std::string(s.status().message()));
  }
}

absl::StatusOr<JobRecord> BakeScheduler::LoadJob(const std::string& job_id) {
  if (job_id.empty()) return absl::InvalidArgumentError("job_id: required");
  if (auto hit = HitRecordFromId(job_id)) return std::move(*hit);
  auto r = jobs_->Get(job_id);
  if (!r.ok()) return r.status();
  if (!r->has_value()) return absl::NotFoundError(absl::StrCat("job_id: no job \"", job_id.substr(0, 100), "\""));
  return std::move(**r);
}

v1::Job BakeScheduler::View(const JobRecord& record) {
  v1::Job job = record.job;
  if (!record.leader_job_id.empty() && !IsTerminal(job.state())) {
    // A follower shows its leader's bake.
    auto leader = jobs_->Get(record.leader_job_id);
    if (leader.ok() && leader->has_value()) {
      const v1::Job& l = (*leader)->job;
      job.set_state(l.state());
      job.set_progress(l.progress());
      job.set_stage(l.stage());
      job.set_attempts(l.attempts());
      CopyAttemptHistory(l, job);
      if (l.has_error()) *job.mutable_error() = l.error();
      job.set_updated_ms(std::max(job.updated_ms(), l.updated_ms()));
    }
  }
  if (record.requester_cancelled) {
    job.set_state(v1::JOB_STATE_CANCELLED);
    job.set_stage("cancelled");
    job.mutable_error()->set_code(static_cast<int>(absl::StatusCode::kCancelled));
    job.mutable_error()->set_message("cancelled by CancelJob");
  }
  // A requester failed by its quality gate still sees the result, so the
  // atlases can be inspected.
  const bool gate_failed = job.state() == v1::JOB_STATE_FAILED && HasQualityGate(record.gate) &&
                           job.error().code() == static_cast<int>(absl::StatusCode::kFailedPrecondition);
  if (job.state() == v1::JOB_STATE_SUCCEEDED || gate_failed) {
    auto result = jobs_->GetResult(job.cache_key());
    if (result.ok() && result->has_value()) *job.mutable_result() = std::move(**result);
  }
  return job;
}

uint64_t BakeScheduler::change_count() {
  std::lock_guard lock(mu_);
  return changes_;
}

uint64_t BakeScheduler::WaitForChange(uint64_t seen, Deadline deadline) {
  std::unique_lock lock(mu_);
  changed_.wait_until(lock, deadline, [&]() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) { return shutdown_ || changes_ != seen; });
  return changes_;
}

void BakeScheduler::Shutdown() {
  std::lock_guard lock(mu_);
  shutdown_ = true;
  stopping_ = true;
  changed_.notify_all();
}

bool BakeScheduler::shutting_down() {
  std::lock_guard lock(mu_);
  return shutdown_;
}

absl::StatusOr<std::string> BakeScheduler::JobOwner(const std::string& job_id) {
  std::lock_guard lock(mu_);
  auto r = LoadJob(job_id);
  if (!r.ok()) return r.status();
  return r->owner;
}

absl::StatusOr<int64_t> BakeScheduler::CountPendingOwnedBy(const std::string& owner) {
  std::lock_guard lock(mu_);
  return jobs_->CountPendingOwnedBy(owner);
}

}  // namespace impostor
