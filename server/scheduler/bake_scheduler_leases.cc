// Leases: a worker asking for work gets the next eligible job (priority, then fairness), reports
// progress, completes or fails it; a failure is retried elsewhere or ends the job.
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
#include "common/request/worker_fit.h"
#include "absl/strings/match.h"
#include "server/store/attempt_history.h"
#include "server/store/database_full.h"
#include "server/scheduler/scheduler_internal.h"
#include "server/scheduler/worker_strength.h"

namespace impostor {

using scheduler_internal::ToDigest;

absl::StatusOr<std::optional<v1::LeasedJob>> BakeScheduler::Lease(const v1::LeaseJobRequest& request,
                                                                   Deadline deadline,
                                                                   const std::function<bool()>& caller_gone,
                                                                   const std::string& lease_holder,
                                                                   bool bind_worker_id) {
  if (request.worker_id().empty()) return absl::InvalidArgumentError("worker_id: required");
  if (request.worker_id().size() > kMaxWorkerIdBytes) {
    return absl::InvalidArgumentError(absl::StrCat("worker_id: ", request.worker_id().size(),
                                                   " bytes, the limit is ", kMaxWorkerIdBytes));
  }
  if (request.wait_seconds() > 60) {
    return absl::InvalidArgumentError(absl::StrCat("wait_seconds: ", request.wait_seconds(), " is over the limit of 60"));
  }
  if (auto s = ValidateCapabilities(request.capabilities()); !s.ok()) return s;
  std::unique_lock lock(mu_);
  if (auto seen = workers_.find(request.worker_id());
      bind_worker_id && !lease_holder.empty() && seen != workers_.end() && !seen->second.token.empty() &&
      seen->second.token != lease_holder) {
    // Gone quiet for a lease timeout: the id is free again (a token renamed).
    const bool about = seen->second.polling > 0 ||
                       options_.now_ms() - seen->second.last_seen_ms < options_.lease_timeout_ms;
    if (about) {
      return absl::PermissionDeniedError(absl::StrCat(
          "worker_id: \"", EscapeUntrusted(request.worker_id(), 128),
          "\" is in use by another worker token; give this worker a --name of its own"));
    }
  }
  NoteWorkerSeen(request.worker_id());
  if (bind_worker_id && !lease_holder.empty()) workers_[request.worker_id()].token = lease_holder;
  workers_[request.worker_id()].device = std::string(Utf8Prefix(request.device(), 256));
  if (request.has_capabilities()) workers_[request.worker_id()].capabilities = request.capabilities();
  // Counted as polling while it waits here (destroyed before `lock`).
  ++workers_[request.worker_id()].polling;
  struct PollEnd {
    std::map<std::string, WorkerSeen>* workers;
    const std::string& id;
    ~PollEnd() {
      if (auto it = workers->find(id); it != workers->end() && it->second.polling > 0) --it->second.polling;
    }
  } poll_end{&workers_, request.worker_id()};
  int lost_claims = 0;
  while (true) {
    if (shutdown_) return absl::UnavailableError("LeaseJob: the server is shutting down; lease from the next one");
    absl::StatusOr<std::vector<std::string>> candidates = std::vector<std::string>();
    // A paused worker waits as if the queue were empty.
    if (!IsPaused(request.worker_id())) candidates = LeaseCandidates(request.worker_id());
    if (!candidates.ok()) return candidates.status();
    std::optional<JobRecord> claimed;
    // A caller that gave up while this call waited (for the lock behind a
    // database outage, say) would never start the job: claim nothing.
    if (caller_gone && caller_gone()) return std::optional<v1::LeasedJob>();
    if (!candidates->empty()) {
      const int64_t now = SharedNowMs();
      // The claim is atomic in the store: when another server took every
      // candidate first, look again at once (the queue moved).
      auto got = jobs_->ClaimQueued(*candidates, {.lease_id = NewId("lease-"),
                                                  .lease_deadline_ms = now + options_.lease_timeout_ms,
                                                  .worker_id = request.worker_id(),
                                                  .lease_holder = lease_holder,
                                                  .now_ms = now,
                                                  .device = workers_[request.worker_id()].device});
      if (!got.ok()) return got.status();
      if (!got->has_value() && ++lost_claims < 16) continue;
      claimed = std::move(*got);
    }
    if (claimed.has_value() && caller_gone && caller_gone()) {
      // Gone while the claim itself waited on the database: hand the job
      // back at once, the attempt not counted, rather than let the lease
      // expire (a lost attempt, and a failure streak for a worker that
      // never had the job).
      JobRecord& r = *claimed;
      HandBack(r, "the worker's LeaseJob call ended before the lease reached it");
      if (auto saved = Save(r); !saved.ok()) return saved;
      spdlog::info("event=lease_unclaimed job={} worker=\"{}\" reason=\"caller gone\"", r.job.job_id(),
                   EscapeUntrusted(request.worker_id()));
      return std::optional<v1::LeasedJob>();
    }
    if (claimed.has_value()) {
      JobRecord& r = *claimed;
      const int64_t now = SharedNowMs();
      ++changes_;
      changed_.notify_all();
      if (auto s = jobs_->NoteServed(r.client_id); !s.ok()) {
        // Only fairness depends on it: the lease stands.
        spdlog::warn("event=note_served_failed client=\"{}\" error=\"{}\"", EscapeUntrusted(r.client_id),
                     std::string(s.message()));
      }
      v1::LeasedJob leased;
      leased.set_job_id(r.job.job_id());
      leased.set_lease_id(r.lease_id);
      leased.set_cache_key(r.job.cache_key());
      *leased.mutable_mesh() = r.mesh;
      *leased.mutable_parameters() = r.parameters;
      leased.set_lease_deadline_ms(r.lease_deadline_ms);
      leased.set_attempt(r.job.attempts());
      spdlog::info("event=lease job={} worker=\"{}\" attempt={} priority={} client=\"{}\"", r.job.job_id(),
                   EscapeUntrusted(request.worker_id()), r.job.attempts(), r.lease_priority,
                   EscapeUntrusted(r.client_id));
      observer_.load()->OnLease(request.worker_id(), r.parameters.product(), r.job.attempts(),
                         std::max<int64_t>(0, now - r.job.created_ms()) / 1000.0);
      return std::optional<v1::LeasedJob>(std::move(leased));
    }
    const auto now = std::chrono::steady_clock::now();
    if (shutdown_ || now >= deadline || (caller_gone && caller_gone())) return std::optional<v1::LeasedJob>();
    const uint64_t seen = changes_;
    changed_.wait_until(lock, std::min(deadline, now + std::chrono::seconds(1)),
                        [&]() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) { return shutdown_ || changes_ != seen; });
  }
}

absl::StatusOr<std::vector<std::string>> BakeScheduler::LeaseCandidates(const std::string& worker_id) {
  // A queue head this worker failed lately is held back, and the queue read
  // again without it for what lies behind (its client's next job, a lower
  // priority): the worker bakes other work while the job waits for another
  // worker.
  const int64_t now = SharedNowMs();
  std::vector<JobRecord> heads;
  std::vector<JobRecord> held_back;
  std::vector<std::string> skipped;
  for (int round = 0; round < kLeaseCandidateRounds && heads.empty(); ++round) {
    auto got = jobs_->QueueHeadsPerClient(skipped);
    if (!got.ok()) return got.status();
    if (got->empty()) break;
    for (JobRecord& r : *got) {
      // Placement: a job this worker cannot hold is never offered to it,
      // and the queue is read again without it (issue 44).
      if (!FitsWorker(r, worker_id)) {
        skipped.push_back(r.job.job_id());
        if (auto s = JudgePlacement(r); !s.ok()) return s;
        continue;
      }
      if (!unplaceable_since_.empty()) unplaceable_since_.erase(r.job.job_id());
      // Preference: a large bake a stronger worker about could take waits
      // for it (up to options_.prefer_strong_ms), and this worker reads on
      // for a job it may take.
      if (const std::string stronger = StrongerWorkerFor(r, worker_id, now); !stronger.empty()) {
        skipped.push_back(r.job.job_id());
        const std::string stage = StrongerWorkerStage(stronger, options_.prefer_strong_ms);
        if (r.job.stage() != stage) {
          spdlog::info("event=lease_held_back job={} worker=\"{}\" reason=\"{}\"", r.job.job_id(),
                       EscapeUntrusted(worker_id), stage);
          r.job.set_stage(stage);
          if (auto s = Save(r); !s.ok()) return s;
        }
        continue;
      }
      if (FailedLatelyBy(r, worker_id, now)) {
        skipped.push_back(r.job.job_id());
        held_back.push_back(std::move(r));
      } else {
        heads.push_back(std::move(r));
      }
    }
  }
  // Nothing else for it: it gets its own failures back unless another
  // worker could take them, so no job waits longer than the bound.
  if (heads.empty()) {
    for (JobRecord& r : held_back) {
      if (!AnotherWorkerMayTake(r, worker_id)) heads.push_back(std::move(r));
    }
    if (heads.empty() && !held_back.empty()) {
      spdlog::debug("event=lease_held_back worker=\"{}\" jobs={} reason=\"failed here lately; left to other workers\"",
                    EscapeUntrusted(worker_id), held_back.size());
    }
  }
  // A pool's share owed to a team goes before the order below
  // (options_.pools), even a higher priority's.
  std::vector<std::string> ids;
  if (heads.size() <= 1) {
    if (auto s = PreferOwedTeams(heads, worker_id, skipped); !s.ok()) return s;
    for (const JobRecord& r : heads) ids.push_back(r.job.job_id());
    return ids;
  }
  auto running = jobs_->RunningPerClient();
  if (!running.ok()) return running.status();
  auto last_served = jobs_->LastServed();
  if (!last_served.ok()) return last_served.status();
  auto rank = [&](const JobRecord& r) {
    const auto busy = running->find(r.client_id);
    const auto served = last_served->find(r.client_id);
    // Heads share one priority, except jobs handed back to their worker
    // above (read in different rounds).
    return std::make_tuple(-int64_t{r.lease_priority}, busy == running->end() ? int64_t{0} : busy->second,
                           served == last_served->end() ? int64_t{0} : served->second, r.job.created_ms(),
                           r.job.job_id());
  };
  std::sort(heads.begin(), heads.end(), [&](const JobRecord& a, const JobRecord& b) { return rank(a) < rank(b); });
  if (auto s = PreferOwedTeams(heads, worker_id, skipped); !s.ok()) return s;
  for (const JobRecord& r : heads) ids.push_back(r.job.job_id());
  return ids;
}

bool BakeScheduler::FitsWorker(const JobRecord& r, const std::string& worker_id) {
  const auto w = workers_.find(worker_id);
  const v1::WorkerCapabilities* caps =
      w == workers_.end() || !w->second.capabilities ? nullptr : &*w->second.capabilities;
  if (!HasRequiredTags(caps, r.required_tags)) return false;
  return caps == nullptr || !WorkerShortfall(r.parameters, *caps).has_value();
}

absl::Status BakeScheduler::JudgePlacement(JobRecord& r) {
  const int64_t now = options_.now_ms();
  std::vector<v1::WorkerCapabilities> about;
  for (const auto& [id, w] : workers_) {
    if (w.polling == 0 && now - w.last_seen_ms >= options_.lease_timeout_ms) continue;
    if (!w.capabilities) {
      if (r.required_tags.empty()) return absl::OkStatus();  // reports nothing: may take it
      about.emplace_back();  // reports no tags
      continue;
    }
    about.push_back(*w.capabilities);
  }
  const std::string reason = UnplaceableReason(r.parameters, about, r.required_tags);
  const bool waiting_stage = absl::StartsWith(r.job.stage(), "waiting for a worker");
  if (reason.empty()) {
    unplaceable_since_.erase(r.job.job_id());
    if (!waiting_stage) return absl::OkStatus();
    r.job.set_stage("queued");
    return Save(r);
  }
  if (unplaceable_since_.size() >= kMaxUnplaceableTracked) {
    // Jobs cancelled or baked elsewhere while unplaceable leave entries
    // behind: drop those older than any timeout could still need.
    std::erase_if(unplaceable_since_, [&](const auto& e) { return now - e.second > 2 * options_.unplaceable_timeout_ms; });
  }
  const int64_t since = unplaceable_since_.emplace(r.job.job_id(), now).first->second;
  const bool timed_out = !jobs_->SharedWithOtherServers() && now - since >= options_.unplaceable_timeout_ms;
  if (!timed_out) {
    if (r.job.stage() == reason) return absl::OkStatus();
    // Replicas each know only the workers that poll them, so each would
    // write its own reason over the other's at every poll (the stage
    // flipping, a log line and a database write each time): the reason
    // first written stands until a replica places the job.
    if (jobs_->SharedWithOtherServers() && waiting_stage) return absl::OkStatus();
    spdlog::info("event=unplaceable job={} reason=\"{}\"", r.job.job_id(), reason);
    r.job.set_stage(reason);
    return Save(r);
  }
  unplaceable_since_.erase(r.job.job_id());
  r.job.set_state(v1::JOB_STATE_FAILED);
  r.job.set_stage("failed");
  r.job.mutable_error()->set_code(static_cast<int32_t>(absl::StatusCode::kResourceExhausted));
  r.job.mutable_error()->set_message(absl::StrCat("no worker could bake it for ", options_.unplaceable_timeout_ms / 1000,
                                                  " s (--unplaceable-timeout-seconds): ", reason));
  r.job.mutable_error()->set_reason(error_reason::kUnplaceable);
  if (auto s = Save(r); !s.ok()) return s;
  spdlog::info("event=fail job={} reason=unplaceable error=\"{}\"", r.job.job_id(), r.job.error().message());
  return SettleFollowers(r);
}

bool BakeScheduler::FailedLatelyBy(const JobRecord& r, const std::string& worker_id, int64_t shared_now_ms) const {
  if (options_.retry_elsewhere_ms <= 0) return false;
  for (const v1::JobAttempt& a : r.job.attempt_history()) {
    if (a.outcome() == v1::JobAttempt::OUTCOME_FAILED && a.worker_id() == worker_id &&
        shared_now_ms - a.ended_ms() < options_.retry_elsewhere_ms) {
      return true;
    }
  }
  return false;
}

bool BakeScheduler::IsAbout(const WorkerSeen& seen) const {
  return seen.polling > 0 || options_.now_ms() - seen.last_seen_ms < options_.lease_timeout_ms;
}

std::string BakeScheduler::StrongerWorkerFor(const JobRecord& r, const std::string& worker_id,
                                             int64_t shared_now_ms) {
  if (options_.prefer_strong_ms <= 0 || !IsLargeBake(r.parameters)) return "";
  const auto asker = workers_.find(worker_id);
  const int asker_strength = asker == workers_.end() || !asker->second.capabilities
                                 ? 0
                                 : WorkerStrength(&*asker->second.capabilities);
  // Queued since it was created or its last attempt ended: stored times on
  // the shared clock, so every server on the database agrees on the bound.
  int64_t queued_since = r.job.created_ms();
  for (const v1::JobAttempt& a : r.job.attempt_history()) queued_since = std::max(queued_since, a.ended_ms());
  const int64_t waited = std::max<int64_t>(0, shared_now_ms - queued_since);
  int strongest = 0;
  std::string kind;
  for (const auto& [id, seen] : workers_) {
    if (id == worker_id || !seen.capabilities || !IsAbout(seen) || IsPaused(id)) continue;
    const int strength = WorkerStrength(&*seen.capabilities);
    if (strength <= strongest || !FitsWorker(r, id) || FailedLatelyBy(r, id, shared_now_ms)) continue;
    strongest = strength;
    kind = seen.capabilities->device_kind();
  }
  if (!HoldForStrongerWorker(r.parameters, asker_strength, strongest, waited, options_.prefer_strong_ms)) return "";
  return kind;
}

bool BakeScheduler::AnotherWorkerMayTake(const JobRecord& r, const std::string& worker_id) {
  const int64_t now = options_.now_ms();
  const int64_t shared_now = SharedNowMs();
  for (const auto& [id, seen] : workers_) {
    if (id == worker_id || IsPaused(id)) continue;
    const bool about = seen.polling > 0 || now - seen.last_seen_ms < options_.lease_timeout_ms;
    if (about && !FailedLatelyBy(r, id, shared_now)) return true;
  }
  return false;
}

absl::StatusOr<JobRecord> BakeScheduler::HeldLease(const std::string& job_id, const std::string& lease_id) {
  if (lease_id.empty()) return absl::InvalidArgumentError("lease_id: required");
  auto r = LoadJob(job_id);
  if (!r.ok()) return r.status();
  if (r->lease_id != lease_id) {
    return absl::FailedPreconditionError(
        absl::StrCat("lease_id: job ", job_id, " is not leased under ", lease_id.substr(0, 80),
                     " (the lease expired or moved to another worker)"));
  }
  return r;
}

absl::StatusOr<v1::ReportProgressResponse> BakeScheduler::ReportProgress(const v1::ReportProgressRequest& request) {
  if (!(request.progress() >= 0.0f && request.progress() <= 1.0f)) {
    return absl::InvalidArgumentError(absl::StrCat("progress: ", request.progress(), " is out of range 0..1"));
  }
  std::lock_guard lock(mu_);
  auto r = HeldLease(request.job_id(), request.lease_id());
  if (!r.ok()) return r.status();
  v1::ReportProgressResponse response;
  if (r->job.state() == v1::JOB_STATE_CANCELLED) {
    response.set_cancel_requested(true);
    return response;
  }
  if (r->job.state() != v1::JOB_STATE_RUNNING) {
    return absl::FailedPreconditionError(absl::StrCat("job ", request.job_id(), " is no longer running"));
  }
  NoteWorkerSeen(r->worker_id);
  r->lease_deadline_ms = SharedNowMs() + options_.lease_timeout_ms;
  r->job.set_progress(request.progress());
  if (!request.stage().empty()) r->job.set_stage(std::string(Utf8Prefix(request.stage(), 64)));
  if (auto s = Save(*r); !s.ok()) return s;
  response.set_lease_deadline_ms(r->lease_deadline_ms);
  return response;
}

absl::Status BakeScheduler::Complete(const v1::CompleteJobRequest& request) {
  std::lock_guard lock(mu_);
  auto r = HeldLease(request.job_id(), request.lease_id());
  if (!r.ok()) return r.status();
  v1::Manifest m = request.result();
  // Who baked it is the server's word, not the worker's (purge --worker).
  m.set_baked_by(r->lease_holder);
  if (m.cache_key() != r->job.cache_key()) {
    return absl::InvalidArgumentError(absl::StrCat("result.cache_key: ", m.cache_key().substr(0, 80),
                                                   " differs from the job's ", r->job.cache_key()));
  }
  if (m.maps_size() == 0) return absl::InvalidArgumentError("result.maps: empty");
  if (!blobs_->Contains(ToDigest(m.manifest_json()))) {
    return absl::FailedPreconditionError("result.manifest_json: blob is not in the store; upload it first");
  }
  // ... and in the manifest.json clients install (server/scheduler/manifest_stamp.h).
  if (!m.baked_by().empty()) {
    auto stamped = StampBakedBy(*blobs_, m.manifest_json(), m.baked_by());
    if (!stamped.ok()) return stamped.status();
    *m.mutable_manifest_json() = *stamped;
  }
  for (int i = 0; i < m.maps_size(); ++i) {
    if (!blobs_->Contains(ToDigest(m.maps(i).digest()))) {
      return absl::FailedPreconditionError(absl::StrCat("result.maps[", i, "] (", m.maps(i).file(),
                                                        "): blob is not in the store; upload it first"));
    }
  }
  // Even a cancelled job's result is good: keep it for the next request.
  hot_results_.Erase(m.cache_key());  // a re-bake replaces the row; the next read remembers it
  if (auto s = jobs_->PutResult(m, SharedNowMs()); !s.ok()) return s;
  CloseAttempt(r->job, v1::JobAttempt::OUTCOME_SUCCEEDED, "", SharedNowMs());
  if (r->job.state() == v1::JOB_STATE_RUNNING) ApplyResult(*r, m);
  r->lease_id.clear();
  if (auto s = Save(*r); !s.ok()) return s;
  if (auto s = SettleFollowers(*r, &m); !s.ok()) return s;
  streaks_.erase(r->worker_id);
  NoteWorkerSeen(r->worker_id);
  observer_.load()->OnComplete(r->worker_id, m);
  spdlog::info("event=complete job={} cache_key={} worker=\"{}\" seconds={:.2f}", r->job.job_id(), m.cache_key(),
               EscapeUntrusted(r->worker_id), m.timings().total_seconds());
  return absl::OkStatus();
}

absl::Status BakeScheduler::Fail(const v1::FailJobRequest& received) {
  std::lock_guard lock(mu_);
  auto r = HeldLease(received.job_id(), received.lease_id());
  if (!r.ok()) return r.status();
  // The error reaches the submitter as the job's error: a real code, some
  // words, and no more than a screenful of them.
  const int32_t code = received.error().code();
  if (code < 1 || code > 16) {
    return absl::InvalidArgumentError(
        absl::StrCat("error.code: ", code, " is not a gRPC status code of a failure (1..16)"));
  }
  v1::FailJobRequest request = received;
  if (request.error().message().empty()) request.mutable_error()->set_message("the worker gave no reason");
  request.mutable_error()->set_message(std::string(Utf8Prefix(request.error().message(), kMaxJobErrorBytes)));
  r->lease_id.clear();
  CloseAttempt(r->job, v1::JobAttempt::OUTCOME_FAILED, request.error().message(), SharedNowMs());
  const bool was_running = r->job.state() == v1::JOB_STATE_RUNNING;
  // This server's own full storage, which the worker relays (reason
  // STORE_FULL or DATABASE_FULL) when its result upload or CompleteJob met
  // it for longer than its outage budget: the farm's state, neither the
  // job's nor the worker's. Such an attempt does not count (as a release),
  // so a full disk never fails a bake for good (three such attempts did),
  // and not against the worker (one full disk would pause every worker).
  const std::string& reason = received.error().reason();
  const bool servers_storage =
      request.retryable() && (reason == error_reason::kStoreFull || reason == error_reason::kDatabaseFull);
  if (was_running && servers_storage) r->job.set_attempts(r->job.attempts() > 0 ? r->job.attempts() - 1 : 0);
  const bool retry = request.retryable() && r->job.attempts() < options_.max_attempts;
  if (was_running) {
    if (retry) {
      r->job.set_state(v1::JOB_STATE_QUEUED);
      r->job.set_stage("queued");
    } else {
      r->job.set_state(v1::JOB_STATE_FAILED);
      r->job.set_stage("failed");
      *r->job.mutable_error() = request.error();
      if (request.retryable()) {
        r->job.mutable_error()->set_message(absl::StrCat("failed after ", r->job.attempts(),
                                                         " attempts; last error: ", request.error().message()));
      }
    }
  }
  // Logged and counted once recorded: a FailJob refused (a full database)
  // is tried again by the worker.
  if (auto s = Save(*r); !s.ok()) return s;
  if (was_running) {
    // Bad input is the job's fault; anything retryable may be the worker's,
    // except the server's own storage (above).
    const bool worker_fault = request.retryable() && !servers_storage;
    spdlog::info("event=fail job={} worker=\"{}\" retry={} worker_fault={} code={} error=\"{}\"", r->job.job_id(),
                 EscapeUntrusted(r->worker_id), retry, worker_fault, request.error().code(),
                 EscapeUntrusted(request.error().message()));
    if (worker_fault) NoteWorkerFailure(r->worker_id, r->job.job_id());
    NoteWorkerSeen(r->worker_id);
    observer_.load()->OnFail(r->worker_id, r->parameters.product(), retry);
  }
  return SettleFollowers(*r);
}

void BakeScheduler::HandBack(JobRecord& r, std::string_view why) {
  r.lease_id.clear();
  r.lease_deadline_ms = 0;
  CloseAttempt(r.job, v1::JobAttempt::OUTCOME_RELEASED, why, SharedNowMs());
  if (r.job.state() == v1::JOB_STATE_RUNNING) {
    // Handed back, not failed: the attempt does not count.
    r.job.set_attempts(r.job.attempts() > 0 ? r.job.attempts() - 1 : 0);
    r.job.set_state(v1::JOB_STATE_QUEUED);
    r.job.set_stage("queued");
    r.job.set_progress(0.0f);
  }
}

absl::Status BakeScheduler::Release(const v1::ReleaseJobRequest& request) {
  if (request.reason().size() > kMaxReleaseReasonBytes) {
    return absl::InvalidArgumentError(absl::StrCat("reason: ", request.reason().size(), " bytes is over the limit of ",
                                                   kMaxReleaseReasonBytes));
  }
  std::lock_guard lock(mu_);
  auto r = HeldLease(request.job_id(), request.lease_id());
  if (!r.ok()) return r.status();
  HandBack(*r, request.reason());
  spdlog::info("event=release job={} worker={} reason=\"{}\"", r->job.job_id(), r->worker_id,
               EscapeUntrusted(request.reason(), 200));
  return Save(*r);
}

absl::StatusOr<std::string> BakeScheduler::JobLeaseHolder(const std::string& job_id) {
  std::lock_guard lock(mu_);
  auto r = LoadJob(job_id);
  if (!r.ok()) return r.status();
  return r->lease_id.empty() ? std::string() : r->lease_holder;
}

absl::StatusOr<bool> BakeScheduler::IsInputOfLeasedJob(const std::string& lease_holder, const std::string& hash) {
  std::lock_guard lock(mu_);
  auto held = jobs_->RunningLeasedBy(lease_holder);
  if (!held.ok()) return held.status();
  for (const JobRecord& r : *held) {
    if (r.mesh.entry().digest().hash() == hash) return true;
    for (const auto& f : r.mesh.files()) {
      if (f.digest().hash() == hash) return true;
    }
  }
  return false;
}

}  // namespace impostor
