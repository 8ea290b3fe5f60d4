// A request arriving: its id checked, a retried submit answered as before, a cache hit answered
// from the stored result (with or without a job row), a new bake queued or joined to the one
// already running for its key (a follower); lookups, job reads and cancels.
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
#include "server/scheduler/hit_job_id.h"

namespace impostor {

using scheduler_internal::IsTerminal;
using scheduler_internal::ToDigest;

std::optional<JobRecord> BakeScheduler::HitRecordFromId(const std::string& job_id) {
  const std::optional<HitId> hit = ParseHitJobId(job_id);
  if (!hit) return std::nullopt;
  // A hit lives as long as its result: once evicted, the id is unknown.
  auto result = jobs_->GetResult(hit->cache_key);
  if (!result.ok() || !result->has_value()) return std::nullopt;
  JobRecord r;
  r.job.set_job_id(job_id);
  r.job.set_cache_key(hit->cache_key);
  r.job.set_state(v1::JOB_STATE_SUCCEEDED);
  r.job.set_progress(1.0f);
  r.job.set_stage("cached");
  r.job.set_cached(true);
  r.owner = hit->owner;
  return r;
}

absl::Status BakeScheduler::RequireInputBlobs(const v1::MeshInput& mesh) const {
  auto require_blob = [&](const std::string& field, const v1::InputFile& f) -> absl::Status {
    if (blobs_->Contains(ToDigest(f.digest()))) return absl::OkStatus();
    return WithErrorReason(
        absl::FailedPreconditionError(absl::StrCat(field, " (\"", f.path(), "\"): blob ", f.digest().hash(), "/",
                                                   f.digest().size_bytes(), " is not in the store; upload it first")),
        error_reason::kInputBlobMissing);
  };
  if (auto s = require_blob("mesh.entry", mesh.entry()); !s.ok()) return s;
  for (int i = 0; i < mesh.files_size(); ++i) {
    if (auto s = require_blob(absl::StrCat("mesh.files[", i, "]"), mesh.files(i)); !s.ok()) return s;
  }
  return absl::OkStatus();
}

absl::StatusOr<std::optional<v1::SubmitBakeResponse>> BakeScheduler::RetryAnswer(const NormalizedBakeRequest& request,
                                                                                  const std::string& requester) {
  const std::string& key = request.cache_key;
  if (request.request_id.empty()) return std::nullopt;
  auto seen = jobs_->FindByRequestId(requester, request.request_id);
  if (!seen.ok()) return seen.status();
  if (!seen->has_value()) return std::nullopt;
  const JobRecord& first = **seen;
  if (first.job.cache_key() != key) {
    return absl::InvalidArgumentError(absl::StrCat("request_id: \"", request.request_id,
                                                   "\" was already used by this client for job ", first.job.job_id(),
                                                   " with a different mesh or parameters; use a fresh id per submit"));
  }
  v1::SubmitBakeResponse response;
  response.set_job_id(first.job.job_id());
  response.set_cache_key(key);
  response.set_cached(first.job.cached());
  *response.mutable_job() = View(first);
  spdlog::info("event=submit job={} cache_key={} outcome=retry request_id={}", first.job.job_id(), key,
               request.request_id);
  observer_.load()->OnSubmit(request.parameters.product(), SchedulerObserver::SubmitOutcome::kRetry);
  return response;
}

JobRecord BakeScheduler::NewRecord(const NormalizedBakeRequest& request, const std::string& requester,
                                   const std::string& owner) {
  const int64_t now = SharedNowMs();
  JobRecord record;
  record.mesh = request.mesh;
  record.parameters = request.parameters;
  record.job.set_cache_key(request.cache_key);
  record.job.set_created_ms(now);
  record.job.set_updated_ms(now);
  record.client_id = requester;
  record.owner = owner;
  record.request_id = request.request_id;
  record.job.set_priority(request.priority);
  record.lease_priority = request.priority;
  if (request.has_gate) record.gate = request.gate;
  record.required_tags = request.required_tags;
  return record;
}

absl::StatusOr<v1::SubmitBakeResponse> BakeScheduler::AnswerHit(JobRecord& record, const v1::Manifest& result,
                                                                 v1::Product product) {
  const std::string& key = record.job.cache_key();
  TouchResult(key);
  record.job.set_state(v1::JOB_STATE_SUCCEEDED);
  record.job.set_progress(1.0f);
  record.job.set_stage("cached");
  record.job.set_cached(true);
  ApplyResult(record, result);  // the gate judges a cached result too
  // Without a gate the job id itself is the record (HitJobId): GetJob and
  // WatchJob answer from it, and nothing needs a sync. A gated hit keeps
  // its row (its outcome depends on the gate); the caller holds mu_ then.
  if (!HasQualityGate(record.gate)) {
    record.job.set_job_id(HitJobId(key, record.client_id, record.request_id, record.owner));
  } else {
    if (record.job.job_id().empty()) record.job.set_job_id(NewId("job-"));
    if (auto s = jobs_->Insert(record); !s.ok()) {
      // A full disk must not stop cache hits: answer without the record
      // (GetJob on this id is then NOT_FOUND; the result is all it holds).
      if (!absl::IsResourceExhausted(s)) return s;
      spdlog::warn("event=cache_hit_not_recorded cache_key={} error=\"{}\"", key, std::string(s.message()));
    }
  }
  v1::SubmitBakeResponse response;
  response.set_cache_key(key);
  response.set_job_id(record.job.job_id());
  response.set_cached(true);
  *response.mutable_job() = record.job;
  *response.mutable_job()->mutable_result() = result;
  // Debug, not info: at thousands of hits a second the log line per hit
  // cost more than the hit (the metrics count them).
  spdlog::debug("event=submit job={} cache_key={} outcome=cache_hit state={}", record.job.job_id(), key,
                v1::JobState_Name(record.job.state()));
  observer_.load()->OnSubmit(product, SchedulerObserver::SubmitOutcome::kCacheHit);
  return response;
}

absl::StatusOr<v1::SubmitBakeResponse> BakeScheduler::Submit(const v1::SubmitBakeRequest& request,
                                                             const std::string& client_id, const std::string& owner) {
  auto normalized = NormalizeSubmit(request);
  if (!normalized.ok()) return normalized.status();
  return Submit(*normalized, client_id, owner);
}

absl::StatusOr<v1::SubmitBakeResponse> BakeScheduler::Submit(const NormalizedBakeRequest& request,
                                                             const std::string& client_id, const std::string& owner) {
  const std::string requester(Utf8Prefix(client_id, 128));
  const std::string& key = request.cache_key;
  const v1::Product product = request.parameters.product();

  // The common hit (no gate, the result in memory) takes the scheduler's
  // lock only to look for a retried request_id: no row is written.
  if (!request.has_gate && hot_results_.Find(key)) {
    if (!request.request_id.empty()) {
      std::lock_guard lock(mu_);
      auto retry = RetryAnswer(request, requester);
      if (!retry.ok()) return retry.status();
      if (retry->has_value()) return std::move(**retry);
    }
    if (auto s = RequireInputBlobs(request.mesh); !s.ok()) return s;
    if (auto hot = HotResult(key)) {
      JobRecord record = NewRecord(request, requester, owner);
      return AnswerHit(record, *hot, product);
    }
  }

  std::lock_guard lock(mu_);
  // A retried submit (the first one's answer was lost) gets the first job.
  // Looked up before the blob checks: the blobs may have been evicted since.
  auto retry = RetryAnswer(request, requester);
  if (!retry.ok()) return retry.status();
  if (retry->has_value()) return std::move(**retry);
  if (auto s = RequireInputBlobs(request.mesh); !s.ok()) return s;

  v1::SubmitBakeResponse response;
  response.set_cache_key(key);

  auto cached = IntactResult(key);
  if (!cached.ok()) return cached.status();
  JobRecord record = NewRecord(request, requester, owner);
  record.job.set_job_id(NewId("job-"));
  if (cached->has_value()) return AnswerHit(record, **cached, product);

  // Backpressure: refuse new work past the pending limits (a cache hit above
  // costs nothing and is always answered).
  auto pending = jobs_->CountPending("");
  if (!pending.ok()) return pending.status();
  if (*pending >= options_.max_pending_jobs) {
    return WithErrorReason(absl::ResourceExhaustedError(absl::StrCat("pending jobs: ", *pending,
                                                                     " queued or running, the limit is ",
                                                                     options_.max_pending_jobs, "; retry later")),
                           error_reason::kFarmPendingJobs);
  }
  if (!record.client_id.empty()) {
    auto mine = jobs_->CountPending(record.client_id);
    if (!mine.ok()) return mine.status();
    if (*mine >= options_.max_pending_per_client) {
      return WithErrorReason(
          absl::ResourceExhaustedError(absl::StrCat("pending jobs of client \"", record.client_id, "\": ", *mine,
                                                    ", the limit per client is ", options_.max_pending_per_client,
                                                    "; retry later")),
          error_reason::kClientPendingJobs);
    }
  }

  // Another server may insert the key's bake between our look and our
  // insert: the store's one-active-bake-per-key constraint refuses ours,
  // and the second look finds theirs to follow.
  for (int attempt = 0;; ++attempt) {
    auto active = jobs_->ActiveWithKey(key);
    if (!active.ok()) return active.status();
    if (active->has_value()) {
      // Identical request in flight: follow its bake instead of baking again.
      record.leader_job_id = (*active)->job.job_id();
      record.job.set_state(v1::JOB_STATE_QUEUED);
      record.job.set_stage("queued");
      if (auto s = jobs_->Insert(record); !s.ok()) return s;
      ++changes_;
      changed_.notify_all();
      if (auto s = SettleIfLeaderFinished(record.leader_job_id); !s.ok()) return s;
      // The shared bake runs at the highest priority anyone waiting asked for.
      absl::Status refreshed = RefreshLeasePriority(**active);
      if (absl::IsAborted(refreshed)) {
        // Another server changed the leader since we read it: once more on
        // a fresh read.
        auto fresh = LoadJob((*active)->job.job_id());
        refreshed = fresh.ok() ? RefreshLeasePriority(*fresh) : fresh.status();
      }
      if (!refreshed.ok()) return refreshed;
      response.set_job_id(record.job.job_id());
      *response.mutable_job() = View(record);
      spdlog::info("event=submit job={} cache_key={} outcome=shares_bake leader={}", record.job.job_id(), key,
                   record.leader_job_id);
      observer_.load()->OnSubmit(product, SchedulerObserver::SubmitOutcome::kSharedBake);
      return response;
    }

    record.job.set_state(v1::JOB_STATE_QUEUED);
    record.job.set_stage("queued");
    if (auto s = jobs_->Insert(record); !s.ok()) {
      if (absl::IsAlreadyExists(s) && attempt < 3) continue;
      return s;
    }
    break;
  }
  ++changes_;
  changed_.notify_all();
  response.set_job_id(record.job.job_id());
  *response.mutable_job() = record.job;
  spdlog::info("event=submit job={} cache_key={} outcome=queued layout={} frames={} resolution={}",
               record.job.job_id(), key, static_cast<int>(request.parameters.layout()), request.parameters.frames(),
               request.parameters.resolution());
  observer_.load()->OnSubmit(product, SchedulerObserver::SubmitOutcome::kQueued);
  return response;
}

absl::StatusOr<v1::LookupBakeResponse> BakeScheduler::Lookup(const v1::SubmitBakeRequest& request) {
  auto normalized = NormalizeLookup(request);
  if (!normalized.ok()) return normalized.status();
  return Lookup(*normalized);
}

absl::StatusOr<v1::LookupBakeResponse> BakeScheduler::Lookup(const NormalizedBakeRequest& request) {
  v1::LookupBakeResponse response;
  response.set_cache_key(request.cache_key);
  auto cached = ReadIntactResult(response.cache_key());
  if (!cached.ok()) return cached.status();
  if (cached->has_value()) {
    response.set_found(true);
    *response.mutable_result() = std::move(**cached);
  }
  return response;
}

absl::StatusOr<v1::Job> BakeScheduler::GetJob(const std::string& job_id) {
  std::lock_guard lock(mu_);
  auto r = LoadJob(job_id);
  if (!r.ok()) return r.status();
  return View(*r);
}

absl::StatusOr<v1::Job> BakeScheduler::CancelJob(const std::string& job_id) {
  std::lock_guard lock(mu_);
  auto r = LoadJob(job_id);
  if (!r.ok()) return r.status();
  if (IsTerminal(View(*r).state())) return View(*r);
  spdlog::info("event=cancel job=\"{}\"", EscapeUntrusted(job_id, 128));
  if (!r->leader_job_id.empty()) {
    // A follower leaves; the bake goes on for whoever else wants it.
    r->job.set_state(v1::JOB_STATE_CANCELLED);
    r->job.set_stage("cancelled");
    r->job.mutable_error()->set_code(static_cast<int>(absl::StatusCode::kCancelled));
    r->job.mutable_error()->set_message("cancelled by CancelJob");
    if (auto s = Save(*r); !s.ok()) return s;
    auto leader = LoadJob(r->leader_job_id);
    if (!leader.ok()) return leader.status();
    if (auto s = CancelBakeIfUnwanted(*leader); !s.ok()) return s;
    if (auto s = RefreshLeasePriority(*leader); !s.ok()) return s;
    return View(*r);
  }
  r->requester_cancelled = true;
  if (auto s = Save(*r); !s.ok()) return s;
  if (auto s = CancelBakeIfUnwanted(*r); !s.ok()) return s;
  if (auto s = RefreshLeasePriority(*r); !s.ok()) return s;
  return View(*r);
}

}  // namespace impostor
