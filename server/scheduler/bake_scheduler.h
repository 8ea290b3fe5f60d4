// The bake farm's job logic: accepts bakes, answers from the result cache,
// shares identical in-flight bakes, leases jobs to workers, renews and
// expires leases, retries what a dead worker dropped, and records results.
// No gRPC here: the service adapters translate requests and statuses.
//
// State is durable in JobStore; blobs are checked in BlobStore. Every public
// method may be called from any thread: one mutex serialises them and a
// condition variable wakes long polls (LeaseJob) and watchers (WatchJob).
#ifndef IMPOSTOR_SERVER_SCHEDULER_BAKE_SCHEDULER_H_
#define IMPOSTOR_SERVER_SCHEDULER_BAKE_SCHEDULER_H_

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "impostor/v1/bake_service.pb.h"
#include "impostor/v1/worker_service.pb.h"
#include "common/request/normalized_bake_request.h"
#include "server/blobs/blob_store.h"
#include "server/store/job_store.h"
#include "server/scheduler/pool_shares.h"
#include "server/scheduler/result_cache.h"
#include "server/scheduler/scheduler_observer.h"

namespace impostor {

// ReleaseJobRequest.reason limit. (The priority and request_id limits are
// checked before the scheduler: common/request/normalized_bake_request.h.)
inline constexpr size_t kMaxReleaseReasonBytes = 1024;

struct SchedulerOptions {
  // A lease not renewed for this long expires and its job is queued again.
  // Default 30 s; range 1 s .. 1 h.
  int64_t lease_timeout_ms = 30'000;
  // Leases a job gets before it fails for good. Default 3; range 1..100.
  uint32_t max_attempts = 3;
  // QUEUED or RUNNING requests accepted from everyone together, and from one
  // client (SubmitBake's client_id); beyond them SubmitBake answers
  // RESOURCE_EXHAUSTED. Cache hits never count. Defaults 100,000 and 10,000;
  // range >= 1.
  int64_t max_pending_jobs = 100'000;
  int64_t max_pending_per_client = 10'000;
  // Store size cap in bytes (0 = none). Over it, EnforceStoreCap evicts
  // blobs no result or pending job refers to, oldest first, then the least
  // recently used unpinned results and the blobs only they used. Blobs a
  // queued or running job needs, and blobs younger than
  // `eviction_grace_ms` (uploads about to be submitted), are never evicted.
  int64_t store_max_bytes = 0;
  int64_t eviction_grace_ms = 10 * 60'000;
  // A worker whose leases of this many different jobs in a row ended badly
  // (a retryable FailJob, or a lease that expired or whose worker died) is
  // paused: not leased to for `worker_pause_ms`. A completed job resets the
  // count. Defaults 3 and 5 minutes; 0 = never pause.
  int worker_failure_limit = 3;
  int64_t worker_pause_ms = 5 * 60'000;
  // A job a worker failed retryably (FailJob with retryable: memory not
  // free right now, a full scratch, a device error) is left to other
  // workers for this long: that worker's LeaseJob skips it while another
  // job is queued for it, or while another worker that could take it is
  // about (heard from within the lease timeout, not paused, and not one
  // that failed the job within this time too). Alone, or once this has
  // passed, the worker gets the job back, so no job starves. Read from the
  // job's attempt_history, so every server on the database agrees; which
  // workers are about is each server's own knowledge. Default 60 s; range
  // 0 (off) .. 1 h.
  int64_t retry_elsewhere_ms = 60'000;
  // A queued job that no worker heard from can bake (its memory estimate
  // over every worker's totals, or KTX2 maps and no encoder: issue 44)
  // waits with the reason as its stage, and fails with it (reason
  // UNPLACEABLE) once it has waited this long. Judged by the workers this
  // server hears from, so never failed by a server sharing its store with
  // others (the workers that could take it may poll another). Default 1 h;
  // range 1 s .. 30 days.
  int64_t unplaceable_timeout_ms = 3600'000;
  // Preference (issue 44): a large bake (worker_strength.h: 8192 rendered
  // px a side or more) is not leased to a worker while a stronger one
  // (discrete > integrated, virtual, other > cpu) that could take it is
  // about (polling, or heard from within the lease timeout, and not
  // paused); the weaker worker gets the next job it may take, or nothing.
  // Once the bake has been queued this long (since it was created or its
  // last attempt ended, on the shared clock) any eligible worker may take
  // it. Workers that report no device kind neither wait nor are waited
  // for. Which workers are about is each server's own knowledge: a
  // stronger worker polling another replica holds nothing back here.
  // Default 30 s; range 0 (off) .. 1 h.
  int64_t prefer_strong_ms = 30'000;
  // Pools and shares (issue 44, pool_shares.h; --pools, --pool-shares):
  // when a worker of a pool (it reports the pool's tag) asks for work and a
  // team with a share in that pool runs fewer jobs on the pool's workers
  // than its guarantee (GuaranteedWorkers of the pool's workers about, not
  // paused), that team's job goes first, whatever the other jobs'
  // priorities (its own highest priority first among its jobs the worker
  // may take); otherwise the usual order.
  // Running jobs are read from the job store (every server counts the same
  // ones); which workers are in a pool is each server's own knowledge (the
  // tags a worker reported to it), so each server guarantees the shares
  // over the pool's workers it hears from. Default: no pools.
  std::vector<WorkerPool> pools;
  // Finished (SUCCEEDED, FAILED, CANCELLED) job records created longer ago
  // than this are deleted by SweepFinishedJobs, so the database stays
  // bounded. Default 7 days; 0 = keep for ever.
  int64_t job_retention_ms = int64_t{7} * 24 * 3600'000;
  // Results kept in memory for cache hits (see ResultCache); 0 = none. A
  // store shared with other servers never gets them.
  size_t hot_result_entries = 4096;
  // Wall clock in Unix epoch milliseconds; tests substitute a fake.
  std::function<int64_t()> now_ms;
};

class BakeScheduler {
 public:
  using Deadline = std::chrono::steady_clock::time_point;

  // `jobs` and `blobs` must outlive the scheduler.
  BakeScheduler(JobStore* jobs, BlobStore* blobs, SchedulerOptions options);
  // Writes the result use times still held in memory (FlushResultTouches).
  ~BakeScheduler();

  // See BakeService.SubmitBake for outcomes and codes. `client_id` names the
  // requester for per-client limits (may be empty).
  // `owner` is the submitting token's name ('' without tokens), recorded
  // with the job (JobOwner).
  // The request arrives checked, normalised and keyed (NormalizeSubmit).
  absl::StatusOr<v1::SubmitBakeResponse> Submit(const NormalizedBakeRequest& request,
                                                const std::string& client_id = "", const std::string& owner = "");
  // NormalizeSubmit, then the above: for callers holding the wire form.
  absl::StatusOr<v1::SubmitBakeResponse> Submit(const v1::SubmitBakeRequest& request,
                                                const std::string& client_id = "", const std::string& owner = "");
  // See BakeService.LookupBake; the request normalised by NormalizeLookup.
  absl::StatusOr<v1::LookupBakeResponse> Lookup(const NormalizedBakeRequest& request);
  absl::StatusOr<v1::LookupBakeResponse> Lookup(const v1::SubmitBakeRequest& request);
  // NOT_FOUND for an unknown job; INVALID_ARGUMENT for an empty id.
  absl::StatusOr<v1::Job> GetJob(const std::string& job_id);
  absl::StatusOr<v1::Job> CancelJob(const std::string& job_id);
  // NOT_FOUND when nothing is baked under the key (or its blobs are gone).
  absl::StatusOr<v1::Manifest> GetResult(const std::string& cache_key);

  // Pins (or unpins) a result so eviction never drops it.
  // NOT_FOUND when nothing is baked under the key; INVALID_ARGUMENT for a
  // malformed key.
  absl::Status PinResult(const std::string& cache_key, bool pinned);

  struct EvictionStats {
    int blobs_removed = 0;
    int results_removed = 0;
    int64_t bytes_freed = 0;
  };
  // Brings the store under options().store_max_bytes (see there). Cheap when
  // already under it.
  absl::StatusOr<EvictionStats> EnforceStoreCap();

  // What PurgeResultsBakedBy did (AdminService.PurgeWorkerResults).
  struct PurgeStats {
    std::vector<std::string> cache_keys;  // results dropped, least recently used first
    int64_t blobs_removed = 0;
    int64_t bytes_freed = 0;
    int64_t blobs_kept = 0;  // still listed by another result, a pending job's input, or in the grace
  };
  // Drops every result whose Manifest.baked_by is `worker` (issue 14: a
  // compromised worker), so those keys bake again, and removes the blobs only
  // those results listed, under EnforceStoreCap's rules: never a blob
  // another result lists, an input of a queued or running job, or one
  // younger than options().eviction_grace_ms (a bake about to complete may
  // have found it present). A download already streaming keeps its open
  // file. INVALID_ARGUMENT naming `worker` and its limits; INTERNAL on a
  // database or disk error (what was dropped so far stays dropped).
  // (bake_scheduler_purge.cc)
  absl::StatusOr<PurgeStats> PurgeResultsBakedBy(const std::string& worker);

  // Counter bumped on every job change.
  uint64_t change_count();
  // Blocks until the counter differs from `seen`, `deadline` passes or
  // Shutdown is called; returns the counter.
  uint64_t WaitForChange(uint64_t seen, Deadline deadline);

  // Leases a queued job, waiting until `deadline` for one. Order: the
  // highest lease priority first (a shared bake has the highest priority of
  // the requesters still waiting for it); among equal priorities the client
  // with the fewest running jobs, then the one served least recently (so two
  // clients alternate whatever their queue lengths), then the oldest job.
  // `caller_gone` is polled about once a second; when it turns true the
  // wait ends with no job.
  // `lease_holder` is the leasing worker token's name ('' without tokens).
  // With `bind_worker_id` (a worker token), request.worker_id belongs to
  // that token while its worker is about: PERMISSION_DENIED for another.
  absl::StatusOr<std::optional<v1::LeasedJob>> Lease(const v1::LeaseJobRequest& request, Deadline deadline,
                                                     const std::function<bool()>& caller_gone,
                                                     const std::string& lease_holder = "",
                                                     bool bind_worker_id = true);
  absl::StatusOr<v1::ReportProgressResponse> ReportProgress(const v1::ReportProgressRequest& request);
  absl::Status Complete(const v1::CompleteJobRequest& request);
  absl::Status Fail(const v1::FailJobRequest& request);
  // Hands a lease back without counting the attempt: the job is queued
  // again at once. INVALID_ARGUMENT (empty lease_id, reason over
  // kMaxReleaseReasonBytes); NOT_FOUND; FAILED_PRECONDITION (lease not held).
  absl::Status Release(const v1::ReleaseJobRequest& request);

  // What a supervisor that saw the worker process exit knows: its jobs lose
  // their leases now (as if they expired) and `how` (e.g. "killed by signal
  // 11 (SIGSEGV)") goes into the error of a job that runs out of attempts.
  absl::Status WorkerDied(const std::string& worker_id, const std::string& how);
  // At start, on a database no other server shares: the previous server's
  // local workers ("local-<i>-<pid>") died with it (PR_SET_PDEATHSIG), and
  // their hand-back found no server. Their jobs go back to the queue at
  // once without counting the attempt (a server crash is not the job's
  // fault), instead of waiting out the lease and burning an attempt.
  // Returns how many; 0 on a shared database (another replica's local
  // workers may be alive).
  absl::StatusOr<int> ReleaseLeasesOfPreviousLocalWorkers();
  // True while `worker_id` is paused for failing too many jobs in a row.
  bool WorkerPaused(const std::string& worker_id);

  // Queues again (or fails, when out of attempts) every job whose lease
  // deadline has passed. Called periodically by the server.
  absl::Status ExpireLeases();

  // --- Serving speed (issue 18) ---
  // A cache hit (SubmitBake, LookupBake, GetResult) notes the result's use
  // time in memory only: a sync per hit would cap hits at the disk's sync
  // rate. This writes the noted times in one transaction; the server calls
  // it periodically and at shutdown, eviction before it orders results, and
  // the destructor. A crash loses at most one period of use times, which
  // only shifts eviction order. Returns how many results were written.
  absl::StatusOr<int64_t> FlushResultTouches();
  // Deletes finished job records older than options().job_retention_ms
  // (nothing when it is 0), in batches so callers are not held up long.
  // Returns how many.
  absl::StatusOr<int64_t> SweepFinishedJobs();

  // Wakes every waiter; later waits return at once, and Lease answers
  // UNAVAILABLE so long-polling workers reconnect to the next server.
  void Shutdown();
  bool shutting_down();

  const SchedulerOptions& options() const { return options_; }

  // --- Observing the farm (metrics, the HTTP adapter in server/http/) ---
  // Events go to `observer` (not owned; null = none) from now on. Call it
  // before the services start; it must outlive the scheduler's use.
  void SetObserver(SchedulerObserver* observer);

  // Rows of the job table per stored state (a follower counts as QUEUED
  // until its shared bake ends).
  absl::StatusOr<std::map<v1::JobState, int64_t>> JobCountsByState();
  // A job as the dashboard shows it: what the requester sees, plus who asked
  // and what for.
  struct JobListing {
    v1::Job job;  // as GetJob (result attached once SUCCEEDED)
    std::string client_id;
    std::string leader_job_id;  // set when it shares another job's bake
    int32_t lease_priority = 0;
    v1::MeshInput mesh;
    v1::BakeParameters parameters;  // normalised
    std::string owner;  // the submitting token's name ('' without tokens)
  };
  // Jobs newest first, of `state` (JOB_STATE_UNSPECIFIED = every state), at
  // most `limit`, strictly after `after` in that order. Results are not
  // attached (see DescribeJob).
  absl::StatusOr<std::vector<JobListing>> ListJobs(v1::JobState state, int limit,
                                                   const std::optional<JobStore::JobCursor>& after);
  // One job with its result. INVALID_ARGUMENT (empty id), NOT_FOUND.
  absl::StatusOr<JobListing> DescribeJob(const std::string& job_id);
  // Baked results newest first, at most `limit`, strictly after `after`.
  absl::StatusOr<std::vector<JobStore::StoredResult>> ListResults(int limit,
                                                                  const std::optional<JobStore::ResultCursor>& after);
  // A result as stored, without verifying its blobs or counting a use (a
  // look must not change eviction order). INVALID_ARGUMENT, NOT_FOUND.
  absl::StatusOr<JobStore::StoredResult> PeekResult(const std::string& cache_key);

  // A worker the scheduler has heard from since it started (LeaseJob and the
  // reports under its leases), or that holds a running job.
  struct WorkerInfo {
    std::string worker_id;
    std::string device;  // LeaseJobRequest.device of its last lease call
    // "busy" (holds a running job), "paused" (failed too many jobs in a
    // row), "idle" (polling for work or heard from within the lease
    // timeout), "offline" (not heard from since).
    std::string state;
    int64_t last_seen_ms = 0;     // Unix ms; 0 = not since this server started
    std::vector<std::string> job_ids;  // running jobs it holds
    int64_t paused_until_ms = 0;
    // What it reported with its last LeaseJob; none from a worker that
    // reports nothing (it is leased anything).
    std::optional<v1::WorkerCapabilities> capabilities;
  };
  // Every known worker, by id. At most kMaxTrackedWorkers heard-from workers
  // are remembered (the least recently seen idle one is forgotten first).
  absl::StatusOr<std::vector<WorkerInfo>> Workers();
  static constexpr size_t kMaxTrackedWorkers = 1024;
  // A pool as this server sees it (options().pools), for the dashboard and
  // metrics: its workers about (polling or heard from within the lease
  // timeout, not paused), the running jobs those hold, and per share the
  // team's running jobs there and its guarantee.
  struct PoolInfo {
    std::string name;
    std::string tag;
    int64_t workers = 0;
    int64_t running = 0;
    struct Share {
      std::string team;
      int percent = 0;
      int64_t guaranteed = 0;  // GuaranteedWorkers(percent, workers)
      int64_t running = 0;
    };
    std::vector<Share> shares;
  };
  // Every configured pool, in flag order. UNAVAILABLE as Workers().
  // (bake_scheduler_pools.cc)
  absl::StatusOr<std::vector<PoolInfo>> Pools();
  static constexpr std::string_view WorkerStateName(int i) {
    constexpr std::string_view kNames[] = {"busy", "paused", "idle", "offline"};
    return kNames[i];
  }

  // OK while the scheduler takes work: not shutting down and the job
  // database answers within kReadyProbeTimeoutMs. UNAVAILABLE otherwise,
  // saying why. Takes no scheduler lock, so it answers in time even while
  // another call waits out a database outage.
  absl::Status CheckReady();
  static constexpr int kReadyProbeTimeoutMs = 2000;
  // A FailJob's message is cut to this many bytes (on a UTF-8 boundary).
  static constexpr size_t kMaxJobErrorBytes = 4096;
  // LeaseJobRequest.worker_id: stored in every job and attempt it leases,
  // and a metrics label.
  static constexpr size_t kMaxWorkerIdBytes = 128;
  // Questions the authorisation layer asks about objects (access_policy.h).
  // The token name that submitted `job_id` ('' for jobs from before tokens);
  // INVALID_ARGUMENT for an empty id, NOT_FOUND for an unknown job.
  absl::StatusOr<std::string> JobOwner(const std::string& job_id);
  // The token name holding `job_id`'s lease ('' when none is held or
  // without tokens); errors as JobOwner.
  absl::StatusOr<std::string> JobLeaseHolder(const std::string& job_id);
  // QUEUED or RUNNING jobs the token `owner` submitted (per-token quota).
  absl::StatusOr<int64_t> CountPendingOwnedBy(const std::string& owner);
  // True when a result lists the blob (its manifest.json or a map).
  absl::StatusOr<bool> IsResultBlob(const std::string& hash);
  // True when `hash` is an input file of a job whose lease `lease_holder`
  // holds now.
  absl::StatusOr<bool> IsInputOfLeasedJob(const std::string& lease_holder, const std::string& hash);

 private:
  absl::StatusOr<JobRecord> LoadJob(const std::string& job_id) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // The result for `key` if present with all of its blobs; a result whose
  // blobs are gone is dropped so the key bakes again (and *dropped, when
  // given, says so: GetResult tells "lost" from "never baked").
  absl::StatusOr<std::optional<v1::Manifest>> IntactResult(const std::string& key, bool* dropped = nullptr)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // The same for the read-only hit paths (LookupBake, GetResult), which
  // also count the use: takes the lock for the database only.
  absl::StatusOr<std::optional<v1::Manifest>> ReadIntactResult(const std::string& key, bool* dropped = nullptr)
      ABSL_LOCKS_EXCLUDED(mu_);
  bool BlobsIntact(const v1::Manifest& m) const;
  // Records a use of the result for LRU eviction, in memory until
  // FlushResultTouches.
  void TouchResult(const std::string& key) ABSL_LOCKS_EXCLUDED(touch_mu_);
  absl::StatusOr<int64_t> FlushTouchesLocked() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // The newest unwritten use of `key` (Unix ms), or 0.
  int64_t UnwrittenUse(const std::string& key) ABSL_LOCKS_EXCLUDED(touch_mu_);
  // A cache hit answered from memory, without the scheduler's lock: the
  // remembered result when all of its blobs are still there (counted as a
  // use), else null and the caller reads the database.
  std::shared_ptr<const v1::Manifest> HotResult(const std::string& key);
  // Every deletion of a result row goes through here, so the result leaves
  // memory (hot_results_) in the same critical section.
  absl::Status DeleteResultLocked(const std::string& key) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // A submit's job record before the cache decides its fate.
  JobRecord NewRecord(const NormalizedBakeRequest& request, const std::string& requester, const std::string& owner);
  // Turns `record` into a cache hit on `result` and answers it (inserting
  // a row only for a gated hit, see Submit).
  absl::StatusOr<v1::SubmitBakeResponse> AnswerHit(JobRecord& record, const v1::Manifest& result,
                                                   v1::Product product);
  // The answer to a retried submit (same client and request_id), if any.
  absl::StatusOr<std::optional<v1::SubmitBakeResponse>> RetryAnswer(const NormalizedBakeRequest& request,
                                                                    const std::string& requester)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // FAILED_PRECONDITION naming the first mesh file not in the blob store.
  absl::Status RequireInputBlobs(const v1::MeshInput& mesh) const;
  // Cache hits without a quality gate get no job row (a row costs a sync):
  // their job id says everything GetJob must answer (see HitJobId), and
  // LoadJob rebuilds the record from it while the result exists.
  std::optional<JobRecord> HitRecordFromId(const std::string& job_id) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  absl::StatusOr<JobRecord> HeldLease(const std::string& job_id, const std::string& lease_id)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  absl::Status Save(JobRecord& record) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // What the requester of `record` sees: its own state, a follower's
  // leader's progress, CANCELLED for a cancelled requester, the result once
  // SUCCEEDED.
  v1::Job View(const JobRecord& record) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Copies a leader's terminal state to its followers still waiting; with
  // `result` (the bake succeeded), each follower gets it through its own
  // quality gate instead (ApplyResult).
  absl::Status SettleFollowers(const JobRecord& leader, const v1::Manifest* result = nullptr)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Settles the leader's waiting followers if it has finished. Called after
  // inserting a follower (its leader may have finished on another server,
  // whose SettleFollowers read the followers before this one was written)
  // and by the lease sweep (a server died between saving a leader and
  // settling its followers).
  absl::Status SettleIfLeaderFinished(const std::string& leader_job_id) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Marks `r` SUCCEEDED with `result`, or FAILED (FAILED_PRECONDITION, the
  // result still attached by View) when its quality gate rejects it. Does
  // not save.
  void ApplyResult(JobRecord& r, const v1::Manifest& result);
  // Sets a queued or running leader's lease priority to the highest
  // priority among its live requesters and saves it when that changed.
  absl::Status RefreshLeasePriority(JobRecord& leader) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // The queued leaders Lease should hand `worker_id`, best first (see
  // Lease): one per client at the highest queued priority, after leaving out
  // the jobs it should leave to others (options_.retry_elsewhere_ms).
  absl::StatusOr<std::vector<std::string>> LeaseCandidates(const std::string& worker_id)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Whether `worker_id` failed `r` within options_.retry_elsewhere_ms of
  // `shared_now_ms` (an attempt of its history that ended FAILED).
  bool FailedLatelyBy(const JobRecord& r, const std::string& worker_id, int64_t shared_now_ms) const;
  // Whether a worker other than `worker_id` that could take `r` is about:
  // heard from within the lease timeout (or polling now), not paused, and
  // not one that failed `r` lately too.
  bool AnotherWorkerMayTake(const JobRecord& r, const std::string& worker_id) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Preference (options_.prefer_strong_ms): the device kind of the
  // strongest worker other than `worker_id` that `r` should wait for (about,
  // not paused, fits `r`, did not fail it lately, and stronger than
  // `worker_id`); "" when `worker_id` may take `r`.
  std::string StrongerWorkerFor(const JobRecord& r, const std::string& worker_id, int64_t shared_now_ms)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Pool shares (options_.pools): puts first in `heads` (sorted best
  // first, not empty) the job of the team the asking worker's pools owe
  // most: its first job there, else its queued job of the highest priority
  // that the worker may take (fits, not held for a stronger worker, not
  // failed by it lately, not in `skipped`: read from the store, at most
  // kOwedTeamLookahead). Leaves the order as it is when no share is owed
  // or no owed team has such a job. (bake_scheduler_pools.cc)
  absl::Status PreferOwedTeams(std::vector<JobRecord>& heads, const std::string& worker_id,
                               const std::vector<std::string>& skipped) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  static constexpr int kOwedTeamLookahead = 16;
  // Whether `worker_id` reported `pool`'s tag; how many workers about here
  // did; and each team's running jobs on those workers.
  bool InPool(const WorkerPool& pool, const std::string& worker_id) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  int64_t PoolWorkersAbout(const WorkerPool& pool) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  std::map<std::string, int64_t> RunningPerTeamInPool(const WorkerPool& pool,
                                                      const std::vector<JobStore::RunningLease>& running) const
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Queue reads LeaseCandidates makes at most, each one skipping the jobs
  // the previous ones found the worker had failed lately.
  static constexpr int kLeaseCandidateRounds = 4;
  // Cancels the leader's bake when neither its requester nor any follower
  // wants it any more.
  absl::Status CancelBakeIfUnwanted(JobRecord& leader) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // A running job whose worker is gone (lease expired, or the process
  // died: `how`): queued again, or failed when out of attempts. Saves.
  // Ends `r`'s lease as handed back (OUTCOME_RELEASED, `why`): a RUNNING
  // job is queued again without counting the attempt. The caller saves it.
  void HandBack(JobRecord& r, std::string_view why) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  absl::Status LoseLease(JobRecord& r, std::string_view how) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // The failure streaks that pause a bad worker (see SchedulerOptions).
  void NoteWorkerFailure(const std::string& worker_id, const std::string& job_id)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  bool IsPaused(const std::string& worker_id) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Unix ms on the clock every server on the job database shares: the
  // local clock (options_.now_ms) plus the store's ClockOffsetMs. Lease
  // deadlines, the lease sweep and stored job times use it, so one server's
  // wrong clock cannot expire the leases another wrote. In-memory per-server
  // times (worker last seen, pauses) stay on the local clock.
  int64_t SharedNowMs() const;
  // True while the lease sweep waits out the grace after a database outage
  // ended (see the .cc); notes a newly ended outage.
  bool LeaseExpiryDeferred() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  JobStore* const jobs_;
  BlobStore* const blobs_;
  const SchedulerOptions options_;

  std::mutex mu_;
  std::condition_variable changed_;
  uint64_t changes_ ABSL_GUARDED_BY(mu_) = 0;
  bool shutdown_ ABSL_GUARDED_BY(mu_) = false;
  std::atomic<bool> stopping_{false};  // shutdown_, for readers without mu_
  // Fairness between clients (which was served least recently) lives in
  // the JobStore (NoteServed, LastServed): shared by every server on one
  // database and kept across restarts.
  // Per worker: the different jobs it failed in a row, and until when it is
  // paused (Unix ms). In memory only: a restart forgives every worker.
  struct WorkerStreak {
    std::vector<std::string> failed_jobs;
    int64_t paused_until_ms = 0;
  };
  std::map<std::string, WorkerStreak> streaks_ ABSL_GUARDED_BY(mu_);
  // Workers heard from (see Workers()). In memory only.
  struct WorkerSeen {
    std::string device;
    // The worker token that leased under this id ('' without tokens): another
    // token may not use the id while this worker is about (its failure
    // streak, pause and attribution are keyed on the id).
    std::string token;
    int64_t last_seen_ms = 0;
    int polling = 0;  // LeaseJob calls waiting now
    std::optional<v1::WorkerCapabilities> capabilities;  // as last reported
  };
  // Whether `seen` asked for work lately: polling now, or heard from within
  // the lease timeout (this server's clock).
  bool IsAbout(const WorkerSeen& seen) const;
  // Placement (issue 44): whether `r` fits what `worker_id` reported (a
  // worker that reported nothing fits everything).
  bool FitsWorker(const JobRecord& r, const std::string& worker_id) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // For a queued job that did not fit the asking worker: when no worker
  // about (heard from within the lease timeout) can bake it, its stage says
  // why, and after unplaceable_timeout_ms it fails with that reason; when
  // one can, a stage saying otherwise is put back to "queued".
  absl::Status JudgePlacement(JobRecord& r) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Since when each job has had no worker that can bake it (Unix ms, this
  // server's clock). In memory only; bounded by the queue.
  std::map<std::string, int64_t> unplaceable_since_ ABSL_GUARDED_BY(mu_);
  static constexpr size_t kMaxUnplaceableTracked = 4096;
  void NoteWorkerSeen(const std::string& worker_id) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Takes mu_ for a read-only view within kViewLockWaitMs; UNAVAILABLE
  // (the outage, or "busy") otherwise.
  absl::Status LockForView(std::unique_lock<std::mutex>& lock);
  static constexpr int kViewLockWaitMs = 5000;
  std::map<std::string, WorkerSeen> workers_ ABSL_GUARDED_BY(mu_);
  // Result use times not yet written (cache key -> Unix ms). Its own lock:
  // hits answered from memory note uses without taking mu_ (order: mu_
  // before touch_mu_).
  std::mutex touch_mu_;
  std::map<std::string, int64_t> touched_ ABSL_GUARDED_BY(touch_mu_);
  // Results served lately, for hits without the database (ResultCache).
  ResultCache hot_results_;
  // EnforceStoreCap on a shared blob directory: when (options_.now_ms) the
  // store is next recounted from the directory even if this process's own
  // count says it is under the cap.
  std::atomic<int64_t> next_shared_recount_ms_{0};
  // jobs_->OutagesRecovered() as the lease sweep last saw it, and until
  // when (options_.now_ms) it expires no lease because of the latest.
  uint64_t outages_seen_ ABSL_GUARDED_BY(mu_) = 0;
  int64_t expiry_resumes_ms_ ABSL_GUARDED_BY(mu_) = 0;
  // DatabaseFullRefusals() as the lease sweep last saw it: a change defers
  // lease expiry for one lease timeout (LeaseExpiryDeferred).
  uint64_t database_full_seen_ ABSL_GUARDED_BY(mu_) = 0;
  // Never null: a do-nothing observer until SetObserver. Atomic: hits
  // answered without mu_ count through it too.
  std::atomic<SchedulerObserver*> observer_;
};

// Random identifier: prefix + 32 hex characters.
std::string NewId(std::string_view prefix);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_SCHEDULER_BAKE_SCHEDULER_H_
