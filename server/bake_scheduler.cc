#include "server/bake_scheduler.h"
#include "server/manifest_stamp.h"

#include <openssl/rand.h>

#include <algorithm>
#include <array>
#include <climits>
#include <map>
#include <tuple>
#include <set>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "common/bake_request.h"
#include "common/error_reason.h"
#include "common/log_escape.h"
#include "common/quality_gate.h"
#include "common/sha256.h"
#include "common/utf8.h"
#include "server/attempt_history.h"
#include "server/database_full.h"

namespace impostor {
namespace {

// Finished leaders whose waiting followers one lease sweep settles.
constexpr int kStrandedLeadersPerSweep = 100;

bool IsTerminal(v1::JobState s) {
  return s == v1::JOB_STATE_SUCCEEDED || s == v1::JOB_STATE_FAILED || s == v1::JOB_STATE_CANCELLED;
}

BlobDigest ToDigest(const v1::Digest& d) { return {d.hash(), d.size_bytes()}; }

SchedulerObserver* NoObserver() {
  static SchedulerObserver none;
  return &none;
}

int64_t SystemNowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// Job ids of cache hits, which get no row: "hit-" + cache key + "-" + 32
// hex characters (a hash of the requester and its request_id, so a retried
// submit gets the same id; random without a request_id) + optionally "-" +
// the owner token's name in hex (what JobOwner answers). The id grants
// nothing: the result it names is readable by every reader already.
constexpr std::string_view kHitPrefix = "hit-";
constexpr size_t kHitTagChars = 32;

std::string ToHex(std::string_view bytes) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  for (unsigned char b : bytes) {
    out.push_back(kHex[b >> 4]);
    out.push_back(kHex[b & 0xf]);
  }
  return out;
}

std::string HitJobId(const std::string& key, const std::string& requester, const std::string& request_id,
                     const std::string& owner) {
  std::string id = std::string(kHitPrefix) + key + "-";
  if (request_id.empty()) {
    id += NewId("").substr(0, kHitTagChars);
  } else {
    id += Sha256Hex(absl::StrCat(requester, "\n", request_id)).substr(0, kHitTagChars);
  }
  if (!owner.empty()) absl::StrAppend(&id, "-", ToHex(owner));
  return id;
}

struct HitId {
  std::string cache_key;
  std::string owner;
};

std::optional<HitId> ParseHitJobId(std::string_view id) {
  auto is_hex = [](std::string_view s) {
    return std::all_of(s.begin(), s.end(), [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); });
  };
  if (id.substr(0, kHitPrefix.size()) != kHitPrefix) return std::nullopt;
  id.remove_prefix(kHitPrefix.size());
  if (id.size() < 64 + 1 + kHitTagChars || id[64] != '-') return std::nullopt;
  HitId hit{std::string(id.substr(0, 64)), ""};
  if (!IsSha256Hex(hit.cache_key) || !is_hex(id.substr(65, kHitTagChars))) return std::nullopt;
  std::string_view owner = id.substr(65 + kHitTagChars);
  if (owner.empty()) return hit;
  if (owner[0] != '-' || owner.size() < 3 || owner.size() % 2 == 0 || !is_hex(owner.substr(1))) return std::nullopt;
  for (size_t i = 1; i + 1 < owner.size(); i += 2) {
    auto nibble = [](char c) { return c <= '9' ? c - '0' : c - 'a' + 10; };
    hit.owner.push_back(static_cast<char>(nibble(owner[i]) * 16 + nibble(owner[i + 1])));
  }
  return hit;
}

}  // namespace

absl::Status ValidateRequestId(std::string_view request_id) {
  if (request_id.size() > kMaxRequestIdBytes) {
    return absl::InvalidArgumentError(absl::StrCat("request_id: ", request_id.size(), " bytes is over the limit of ",
                                                   kMaxRequestIdBytes));
  }
  for (size_t i = 0; i < request_id.size(); ++i) {
    const char c = request_id[i];
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
    if (!ok) {
      return absl::InvalidArgumentError(absl::StrCat("request_id: byte ", i, " (0x",
                                                     absl::Hex(static_cast<unsigned char>(c), absl::kZeroPad2),
                                                     ") is not one of [A-Za-z0-9_-]"));
    }
  }
  return absl::OkStatus();
}

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

void BakeScheduler::ApplyResult(JobRecord& r, const v1::Manifest& result) {
  r.job.set_state(v1::JOB_STATE_SUCCEEDED);
  r.job.set_progress(1.0f);
  if (r.job.stage() != "cached") r.job.set_stage("done");
  r.job.clear_error();
  const absl::Status gate = CheckQualityGate(r.gate, result);
  if (gate.ok()) return;
  r.job.set_state(v1::JOB_STATE_FAILED);
  r.job.set_stage("quality_gate");
  r.job.mutable_error()->set_code(static_cast<int>(gate.code()));
  r.job.mutable_error()->set_message(std::string(gate.message()));
  spdlog::info("event=quality_gate_failed job={} cache_key={} error=\"{}\"", r.job.job_id(), r.job.cache_key(),
               std::string(gate.message()));
}

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

void BakeScheduler::TouchResult(const std::string& key) {
  const int64_t now = SharedNowMs();
  std::lock_guard lock(touch_mu_);
  touched_[key] = now;
}

int64_t BakeScheduler::UnwrittenUse(const std::string& key) {
  std::lock_guard lock(touch_mu_);
  auto it = touched_.find(key);
  return it == touched_.end() ? 0 : it->second;
}

std::shared_ptr<const v1::Manifest> BakeScheduler::HotResult(const std::string& key) {
  std::shared_ptr<const v1::Manifest> m = hot_results_.Find(key);
  // Blobs are checked on every hit, as from the database: a blob deleted
  // or rotted on disk sends the caller to the path that drops the result.
  if (!m || !BlobsIntact(*m)) return nullptr;
  TouchResult(key);
  return m;
}

absl::Status BakeScheduler::DeleteResultLocked(const std::string& key) {
  hot_results_.Erase(key);
  return jobs_->DeleteResult(key);
}

absl::StatusOr<int64_t> BakeScheduler::FlushTouchesLocked() {
  std::map<std::string, int64_t> batch;
  {
    std::lock_guard lock(touch_mu_);
    batch.swap(touched_);
  }
  if (batch.empty()) return 0;
  // Only eviction order depends on it: a failed write (a full disk) drops
  // the batch rather than fail anything.
  if (auto s = jobs_->TouchResults(batch); !s.ok()) return s;
  return static_cast<int64_t>(batch.size());
}

absl::StatusOr<int64_t> BakeScheduler::FlushResultTouches() {
  std::lock_guard lock(mu_);
  return FlushTouchesLocked();
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

bool BakeScheduler::BlobsIntact(const v1::Manifest& m) const {
  // Verified, not just present: a result whose bytes rotted is a miss.
  bool intact = blobs_->Verify(ToDigest(m.manifest_json())).ok();
  for (const auto& map : m.maps()) intact = intact && blobs_->Verify(ToDigest(map.digest())).ok();
  return intact;
}

absl::StatusOr<std::optional<v1::Manifest>> BakeScheduler::ReadIntactResult(const std::string& key, bool* dropped) {
  if (auto hot = HotResult(key)) return std::optional<v1::Manifest>(*hot);
  std::optional<v1::Manifest> found;
  {
    // Only the database read holds the scheduler's lock: with many callers
    // hitting the cache, the blob checks run side by side.
    std::lock_guard lock(mu_);
    auto result = jobs_->GetResult(key);
    if (!result.ok() || !result->has_value()) return result;
    found = std::move(*result);
    // Under mu_, like every erase: see ResultCache. Hits from memory check
    // the blobs themselves.
    hot_results_.Fill(*found);
    TouchResult(key);
  }
  if (BlobsIntact(*found)) return found;
  std::lock_guard lock(mu_);
  return IntactResult(key, dropped);  // checks again: the result may have been baked anew meanwhile
}

absl::StatusOr<std::optional<v1::Manifest>> BakeScheduler::IntactResult(const std::string& key, bool* dropped) {
  auto result = jobs_->GetResult(key);
  if (!result.ok() || !result->has_value()) return result;
  if (BlobsIntact(**result)) {
    hot_results_.Fill(**result);
    return result;
  }
  spdlog::warn("event=cached_result_incomplete cache_key={} action=rebake", key);
  if (auto s = DeleteResultLocked(key); !s.ok()) return s;
  if (dropped != nullptr) *dropped = true;
  return std::optional<v1::Manifest>();
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

absl::StatusOr<std::optional<v1::SubmitBakeResponse>> BakeScheduler::RetryAnswer(const v1::SubmitBakeRequest& request,
                                                                                  const std::string& requester,
                                                                                  const std::string& key,
                                                                                  v1::Product product) {
  if (request.request_id().empty()) return std::nullopt;
  auto seen = jobs_->FindByRequestId(requester, request.request_id());
  if (!seen.ok()) return seen.status();
  if (!seen->has_value()) return std::nullopt;
  const JobRecord& first = **seen;
  if (first.job.cache_key() != key) {
    return absl::InvalidArgumentError(absl::StrCat("request_id: \"", request.request_id(),
                                                   "\" was already used by this client for job ", first.job.job_id(),
                                                   " with a different mesh or parameters; use a fresh id per submit"));
  }
  v1::SubmitBakeResponse response;
  response.set_job_id(first.job.job_id());
  response.set_cache_key(key);
  response.set_cached(first.job.cached());
  *response.mutable_job() = View(first);
  spdlog::info("event=submit job={} cache_key={} outcome=retry request_id={}", first.job.job_id(), key,
               request.request_id());
  observer_.load()->OnSubmit(product, SchedulerObserver::SubmitOutcome::kRetry);
  return response;
}

JobRecord BakeScheduler::NewRecord(const v1::SubmitBakeRequest& request, const v1::BakeParameters& params,
                                   const std::string& key, const std::string& requester, const std::string& owner) {
  const int64_t now = SharedNowMs();
  JobRecord record;
  record.mesh = request.mesh();
  record.parameters = params;
  record.job.set_cache_key(key);
  record.job.set_created_ms(now);
  record.job.set_updated_ms(now);
  record.client_id = requester;
  record.owner = owner;
  record.request_id = request.request_id();
  record.job.set_priority(request.priority());
  record.lease_priority = request.priority();
  if (HasQualityGate(request.gate())) record.gate = request.gate();
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
  if (auto s = ValidateMeshInput(request.mesh()); !s.ok()) return s;
  auto params = NormalizeParameters(request.parameters());
  if (!params.ok()) return params.status();
  if (request.priority() < kMinPriority || request.priority() > kMaxPriority) {
    return absl::InvalidArgumentError(absl::StrCat("priority: ", request.priority(), " is out of range ", kMinPriority,
                                                   "..", kMaxPriority));
  }
  if (auto s = ValidateQualityGate(request.gate(), "gate"); !s.ok()) return s;
  if (auto s = CheckQualityGateApplies(request.gate(), *params, "gate"); !s.ok()) return s;
  if (auto s = ValidateRequestId(request.request_id()); !s.ok()) return s;
  const std::string requester(Utf8Prefix(client_id, 128));
  const std::string key = ComputeCacheKey(request.mesh(), *params);

  // The common hit (no gate, the result in memory) takes the scheduler's
  // lock only to look for a retried request_id: no row is written.
  if (!HasQualityGate(request.gate()) && hot_results_.Find(key)) {
    if (!request.request_id().empty()) {
      std::lock_guard lock(mu_);
      auto retry = RetryAnswer(request, requester, key, params->product());
      if (!retry.ok()) return retry.status();
      if (retry->has_value()) return std::move(**retry);
    }
    if (auto s = RequireInputBlobs(request.mesh()); !s.ok()) return s;
    if (auto hot = HotResult(key)) {
      JobRecord record = NewRecord(request, *params, key, requester, owner);
      return AnswerHit(record, *hot, params->product());
    }
  }

  std::lock_guard lock(mu_);
  // A retried submit (the first one's answer was lost) gets the first job.
  // Looked up before the blob checks: the blobs may have been evicted since.
  auto retry = RetryAnswer(request, requester, key, params->product());
  if (!retry.ok()) return retry.status();
  if (retry->has_value()) return std::move(**retry);
  if (auto s = RequireInputBlobs(request.mesh()); !s.ok()) return s;

  v1::SubmitBakeResponse response;
  response.set_cache_key(key);

  auto cached = IntactResult(key);
  if (!cached.ok()) return cached.status();
  JobRecord record = NewRecord(request, *params, key, requester, owner);
  record.job.set_job_id(NewId("job-"));
  if (cached->has_value()) return AnswerHit(record, **cached, params->product());

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
      observer_.load()->OnSubmit(params->product(), SchedulerObserver::SubmitOutcome::kSharedBake);
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
               record.job.job_id(), key, static_cast<int>(params->layout()), params->frames(), params->resolution());
  observer_.load()->OnSubmit(params->product(), SchedulerObserver::SubmitOutcome::kQueued);
  return response;
}

absl::StatusOr<v1::LookupBakeResponse> BakeScheduler::Lookup(const v1::SubmitBakeRequest& request) {
  if (auto s = ValidateMeshInput(request.mesh()); !s.ok()) return s;
  auto params = NormalizeParameters(request.parameters());
  if (!params.ok()) return params.status();
  v1::LookupBakeResponse response;
  response.set_cache_key(ComputeCacheKey(request.mesh(), *params));
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

absl::StatusOr<v1::Manifest> BakeScheduler::GetResult(const std::string& cache_key) {
  if (!IsSha256Hex(cache_key)) {
    return absl::InvalidArgumentError(absl::StrCat("cache_key: expected 64 lowercase hex characters, got \"",
                                                    cache_key.substr(0, 80), "\""));
  }
  bool dropped = false;
  auto r = ReadIntactResult(cache_key, &dropped);
  if (!r.ok()) return r.status();
  if (dropped) {
    // Still NOT_FOUND (clients bake on a miss), but saying why: a key a game
    // fetched yesterday is not "never baked".
    return absl::NotFoundError(absl::StrCat("cache_key: the result baked under ", cache_key,
                                            " was damaged on the server (a file failed its digest check) and has "
                                            "been removed; submit the bake again to rebuild it"));
  }
  if (!r->has_value()) return absl::NotFoundError(absl::StrCat("cache_key: nothing baked under ", cache_key));
  return std::move(**r);
}

absl::Status BakeScheduler::PinResult(const std::string& cache_key, bool pinned) {
  if (!IsSha256Hex(cache_key)) {
    return absl::InvalidArgumentError(absl::StrCat("cache_key: expected 64 lowercase hex characters, got \"",
                                                    cache_key.substr(0, 80), "\""));
  }
  std::lock_guard lock(mu_);
  auto found = jobs_->PinResult(cache_key, pinned);
  if (!found.ok()) return found.status();
  if (!*found) return absl::NotFoundError(absl::StrCat("cache_key: nothing baked under ", cache_key));
  spdlog::info("event=pin cache_key={} pinned={}", cache_key, pinned);
  return absl::OkStatus();
}

absl::StatusOr<BakeScheduler::EvictionStats> BakeScheduler::EnforceStoreCap() {
  EvictionStats stats;
  const int64_t cap = options_.store_max_bytes;
  // Replicas on one database share the blob directory too (issue 15): the
  // others' uploads and evictions never reach this process's count, which
  // can be too low (the cap passed unseen) or too high (eviction chasing
  // bytes that are gone). The evicting replica recounts from the
  // directory: whenever its count says over, and every kSharedRecountMs.
  constexpr int64_t kSharedRecountMs = 30'000;
  const bool shared = jobs_->SharedWithOtherServers();
  const int64_t now_ms = options_.now_ms();
  if (cap <= 0 || (blobs_->total_bytes() <= cap && (!shared || now_ms < next_shared_recount_ms_.load()))) {
    return stats;
  }
  std::lock_guard lock(mu_);
  if (shared) next_shared_recount_ms_ = now_ms + kSharedRecountMs;
  // One server on a shared database evicts; the others skip.
  auto maintainer = jobs_->HoldMaintenanceLock();
  if (!maintainer.ok()) return maintainer.status();
  if (!*maintainer) return stats;
  std::vector<BlobStore::StoredBlob> stored = blobs_->List();
  if (shared && blobs_->Recount(stored) <= cap) return stats;
  // Eviction orders results by use: write the uses noted in memory first.
  if (auto s = FlushTouchesLocked(); !s.ok()) return s.status();
  // What must stay: every input of a queued or running job.
  std::set<std::string> needed;
  auto pending = jobs_->Pending();
  if (!pending.ok()) return pending.status();
  for (const JobRecord& r : *pending) {
    needed.insert(r.mesh.entry().digest().hash());
    for (const auto& f : r.mesh.files()) needed.insert(f.digest().hash());
  }
  auto results = jobs_->ResultsByLastUse();
  if (!results.ok()) return results.status();
  std::map<std::string, int> result_refs;
  auto result_blobs = [](const v1::Manifest& m) {
    std::vector<std::string> hashes = {m.manifest_json().hash()};
    for (const auto& map : m.maps()) hashes.push_back(map.digest().hash());
    return hashes;
  };
  for (const auto& r : *results) {
    for (const auto& h : result_blobs(r.manifest)) ++result_refs[h];
  }
  auto remove = [&](const std::string& hash, int64_t size) -> absl::Status {
    if (auto s = blobs_->Remove(hash); !s.ok()) return s;
    ++stats.blobs_removed;
    stats.bytes_freed += size;
    return absl::OkStatus();
  };
  // First, blobs nothing refers to (inputs of finished bakes, orphans),
  // oldest first, sparing recent uploads that may be about to be submitted.
  std::sort(stored.begin(), stored.end(), [](const auto& a, const auto& b) { return a.mtime_ns < b.mtime_ns; });
  std::map<std::string, int64_t> sizes;
  // File times are real time, whatever clock the scheduler runs on.
  const int64_t grace_ns = (SystemNowMs() - options_.eviction_grace_ms) * 1'000'000;
  for (const auto& b : stored) {
    sizes[b.hash] = b.size_bytes;
    if (blobs_->total_bytes() <= cap) break;
    if (needed.count(b.hash) || result_refs.count(b.hash) || b.mtime_ns > grace_ns) continue;
    if (auto s = remove(b.hash, b.size_bytes); !s.ok()) return s;
  }
  // Then whole results, least recently used first, never pinned ones.
  for (const auto& r : *results) {
    if (blobs_->total_bytes() <= cap) break;
    if (r.pinned) continue;
    const std::string& key = r.manifest.cache_key();
    if (auto s = DeleteResultLocked(key); !s.ok()) return s;
    ++stats.results_removed;
    for (const auto& h : result_blobs(r.manifest)) {
      if (--result_refs[h] > 0 || needed.count(h)) continue;
      if (auto s = remove(h, sizes.count(h) ? sizes[h] : 0); !s.ok()) return s;
    }
    spdlog::info("event=evict_result cache_key={}", key);
  }
  if (stats.blobs_removed > 0 || stats.results_removed > 0) {
    observer_.load()->OnEvicted(stats.blobs_removed, stats.results_removed, stats.bytes_freed);
  }
  if (stats.blobs_removed > 0) {
    spdlog::info("event=store_evicted blobs={} results={} bytes={} store_bytes={} cap={}", stats.blobs_removed,
                 stats.results_removed, stats.bytes_freed, blobs_->total_bytes(), cap);
  }
  return stats;
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
  std::vector<std::string> ids;
  if (heads.size() <= 1) {
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
  for (const JobRecord& r : heads) ids.push_back(r.job.job_id());
  return ids;
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
  // ... and in the manifest.json clients install (server/manifest_stamp.h).
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

absl::StatusOr<std::string> BakeScheduler::JobOwner(const std::string& job_id) {
  std::lock_guard lock(mu_);
  auto r = LoadJob(job_id);
  if (!r.ok()) return r.status();
  return r->owner;
}

absl::StatusOr<std::string> BakeScheduler::JobLeaseHolder(const std::string& job_id) {
  std::lock_guard lock(mu_);
  auto r = LoadJob(job_id);
  if (!r.ok()) return r.status();
  return r->lease_id.empty() ? std::string() : r->lease_holder;
}

absl::StatusOr<int64_t> BakeScheduler::CountPendingOwnedBy(const std::string& owner) {
  std::lock_guard lock(mu_);
  return jobs_->CountPendingOwnedBy(owner);
}

absl::StatusOr<bool> BakeScheduler::IsResultBlob(const std::string& hash) {
  std::lock_guard lock(mu_);
  return jobs_->IsResultBlob(hash);
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
