// Durable job and result records: the interface every storage engine
// implements, so one scheduler logic (BakeScheduler) runs on either.
// Engines: SqliteJobStore (sqlite_job_store.h, embedded, one server) and
// PostgresJobStore (postgres/postgres_job_store.h, several replicas on one
// database). OpenJobStore (job_store_factory.h) picks one from the flags.
//
// Plain persistence: no scheduling policy lives here (see BakeScheduler).
// Thread-safety: an engine need not be thread-safe; the owner serialises
// calls (BakeScheduler holds its mutex around every call). Probe,
// Outage, OutagesRecovered and ClockOffsetMs are the exceptions:
// thread-safe, called without that mutex, so
// that a readiness check or a dashboard is never queued behind a statement
// that is waiting out a database outage.
#ifndef IMPOSTOR_SERVER_STORE_JOB_STORE_H_
#define IMPOSTOR_SERVER_STORE_JOB_STORE_H_

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "impostor/v1/types.pb.h"
#include "impostor/v1/worker_service.pb.h"

namespace impostor {

// One job row. Every SubmitBake that is not a cache hit gets its own row.
// The first request for a cache key is the *leader*: its row is the unit of
// work that workers lease. Identical requests that arrive while it is queued
// or running become *followers* (leader_job_id set): they are never leased
// and mirror the leader's progress, so one bake serves them all.
struct JobRecord {
  v1::Job job;                 // state, progress, stage, error, attempts, times
  v1::MeshInput mesh;          // what to bake
  v1::BakeParameters parameters;  // normalised
  std::string lease_id;        // empty unless RUNNING (kept on cancel, see BakeScheduler)
  int64_t lease_deadline_ms = 0;
  std::string worker_id;
  std::string leader_job_id;   // empty for leaders
  // A leader's requester cancelled, but followers still want the bake: the
  // row keeps baking and reports CANCELLED to its own requester only.
  bool requester_cancelled = false;
  std::string client_id;       // who submitted it, for per-client limits
  // Leaders: the priority the queue orders by, the highest of its live
  // requesters' (job.priority() is this requester's own). Column `priority`.
  int32_t lease_priority = 0;
  // This requester's quality gate (SubmitBakeRequest.gate); empty = none.
  v1::QualityGate gate;
  // Tags a worker must have to be leased this job
  // (SubmitBakeRequest.required_tags, normalised); stored in the request
  // column with the gate.
  std::vector<std::string> required_tags;
  // SubmitBakeRequest.request_id ('' = none): a second submit with the same
  // (client_id, request_id) returns this job. Column `request_id`.
  std::string request_id;
  // Leases of this job that expired (the worker died or hung), for the
  // error a job that keeps killing its workers ends with. Column
  // `lease_expiries`.
  int32_t lease_expiries = 0;
  // The token name that submitted the job ('' without tokens): only it (or
  // an admin) may watch, get or cancel the job. Column `owner`.
  std::string owner;
  // The token name of the worker holding the lease ('' when none or without
  // tokens): it may read the job's input blobs. Column `lease_holder`.
  std::string lease_holder;
  // Bumped by every Update: an Update whose row_version differs from the
  // stored one changes nothing (ABORTED), so a replica acting on a stale
  // read (another server leased, completed or cancelled the job since)
  // cannot overwrite the newer state. Column `row_version`.
  int64_t row_version = 0;
};

// What ClaimQueued writes into the job it leases.
struct LeaseGrant {
  std::string lease_id;
  int64_t lease_deadline_ms = 0;
  std::string worker_id;
  std::string lease_holder;
  int64_t now_ms = 0;
  std::string device;  // the worker's LeaseJobRequest.device, for attempt_history
};

// `record` as ClaimQueued leaves it (state, attempts, progress, stage,
// lease, worker, a new attempt_history entry); for engines.
void ApplyLeaseGrant(JobRecord& record, const LeaseGrant& grant);

// For engines' many-row queries: whether a row that did not read (`why`)
// is skipped. A job row that no longer parses (DATA_LOSS) is logged once
// per process and skipped, so one damaged record cannot stop the lease
// sweeper, the queue or the dashboard for every other job (reading it by id
// still answers DATA_LOSS). Anything else fails the query.
bool SkipUnreadableJobRow(const absl::Status& why);

// SQL (both engines) for a job row's state as its requester sees it.
inline constexpr const char* kShownStateSql =
    "(CASE WHEN requester_cancelled <> 0 THEN 5 ELSE state END)";  // 5: JOB_STATE_CANCELLED

class JobStore {
 public:
  // Opens or creates an SQLite database file (SqliteJobStore): the
  // embedded engine, kept here so callers that only know a data directory
  // need not name the engine. INTERNAL with SQLite's message on failure.
  static absl::StatusOr<std::unique_ptr<JobStore>> Open(const std::filesystem::path& file);
  virtual ~JobStore() = default;

  // Stores a new job. ALREADY_EXISTS when the job id, or its (client_id,
  // request_id), is taken, or when it is a QUEUED or RUNNING leader and
  // another one with its cache key exists (one bake per key, whichever
  // server inserts first: a unique index, not an in-process map).
  virtual absl::Status Insert(const JobRecord& record) = 0;
  // Writes every field of an existing job, if its stored row_version is
  // record.row_version (and stores row_version + 1). NOT_FOUND if absent;
  // ABORTED if it changed since it was read.
  virtual absl::Status Update(const JobRecord& record) = 0;
  // Leases the first job of `job_ids` (in that order of preference) that is
  // still a QUEUED leader, in one atomic step that two servers never both
  // win: state RUNNING, attempts + 1, progress 0, stage "leased", the
  // grant's lease, worker and holder, updated at grant.now_ms. The leased
  // record (with its new row_version), or none when every one was taken.
  virtual absl::StatusOr<std::optional<JobRecord>> ClaimQueued(const std::vector<std::string>& job_ids,
                                                               const LeaseGrant& grant) = 0;
  virtual absl::StatusOr<std::optional<JobRecord>> Get(const std::string& job_id) = 0;
  // The oldest QUEUED leader.
  virtual absl::StatusOr<std::optional<JobRecord>> OldestQueued() = 0;
  // For the highest lease priority among QUEUED leaders not listed in
  // `skip_job_ids`: the oldest such leader of each client at that priority
  // (one per client, any order). Empty when nothing else is queued. The
  // scheduler skips the jobs a worker should leave to others (see
  // SchedulerOptions::retry_elsewhere_ms); ids of no queued job are ignored.
  virtual absl::StatusOr<std::vector<JobRecord>> QueueHeadsPerClient(const std::vector<std::string>& skip_job_ids) = 0;
  // RUNNING leaders per client_id (clients with none are absent).
  virtual absl::StatusOr<std::map<std::string, int64_t>> RunningPerClient() = 0;
  // Who holds each RUNNING leader and whose it is (pool shares: every
  // server on the database counts the same running jobs).
  struct RunningLease {
    std::string worker_id;
    std::string client_id;
    std::string owner;
  };
  virtual absl::StatusOr<std::vector<RunningLease>> RunningLeases() = 0;
  // QUEUED leaders of `team` (its owner or its client_id is `team`), the
  // highest lease priority first, then the oldest; at most `limit` (pool
  // shares: a team owed its share gets its job whatever the others'
  // priorities).
  virtual absl::StatusOr<std::vector<JobRecord>> QueuedOfTeam(const std::string& team, int limit) = 0;
  // A QUEUED or RUNNING leader with this cache key.
  virtual absl::StatusOr<std::optional<JobRecord>> ActiveWithKey(const std::string& cache_key) = 0;
  // Followers of `leader_job_id` that are still QUEUED or RUNNING.
  virtual absl::StatusOr<std::vector<JobRecord>> ActiveFollowers(const std::string& leader_job_id) = 0;
  // QUEUED or RUNNING rows, of one client or (client_id empty) of everyone.
  virtual absl::StatusOr<int64_t> CountPending(const std::string& client_id) = 0;
  // The job a submit with this (client_id, request_id) created, if any.
  virtual absl::StatusOr<std::optional<JobRecord>> FindByRequestId(const std::string& client_id,
                                                           const std::string& request_id) = 0;
  // RUNNING leaders leased to `worker_id`.
  virtual absl::StatusOr<std::vector<JobRecord>> RunningOnWorker(const std::string& worker_id) = 0;
  // RUNNING jobs whose lease deadline is before `now_ms`.
  virtual absl::StatusOr<std::vector<JobRecord>> ExpiredLeases(int64_t now_ms) = 0;
  // Finished leaders (SUCCEEDED, FAILED, CANCELLED) that still have QUEUED
  // or RUNNING followers, at most `limit`: a server that died between saving
  // a leader and settling its followers leaves them waiting.
  virtual absl::StatusOr<std::vector<JobRecord>> FinishedLeadersWithWaitingFollowers(int limit) = 0;

  virtual absl::Status PutResult(const v1::Manifest& manifest, int64_t now_ms) = 0;
  virtual absl::StatusOr<std::optional<v1::Manifest>> GetResult(const std::string& cache_key) = 0;
  virtual absl::Status DeleteResult(const std::string& cache_key) = 0;
  // Records a use of the result (cache hit, GetResult) for LRU eviction.
  virtual absl::Status TouchResult(const std::string& cache_key, int64_t now_ms) = 0;
  // Sets or clears the pin; false when no result has that key.
  virtual absl::StatusOr<bool> PinResult(const std::string& cache_key, bool pinned) = 0;
  struct StoredResult {
    v1::Manifest manifest;
    bool pinned = false;
    int64_t created_ms = 0;    // when it was first stored (Unix ms)
    int64_t last_used_ms = 0;  // last cache hit or fetch (Unix ms)
    std::string source_job_id;  // GetStoredResult only: OldestJobWithKey
  };
  // Every result, least recently used first.
  virtual absl::StatusOr<std::vector<StoredResult>> ResultsByLastUse() = 0;
  // Every QUEUED or RUNNING job.
  virtual absl::StatusOr<std::vector<JobRecord>> Pending() = 0;

  // --- Read-only listings for the HTTP adapter (server/http/) ---
  // The state these listings go by is the one the job's requester sees
  // (kShownStateSql): a requester-cancelled leader that baked on for its
  // followers is CANCELLED, as GetJob shows it, not SUCCEEDED.
  // Rows per shown state.
  virtual absl::StatusOr<std::map<int, int64_t>> CountByState() = 0;
  // Position in a newest-first listing: the last row of the previous page.
  struct JobCursor {
    int64_t created_ms = 0;
    std::string job_id;
  };
  // Jobs newest first (created_ms, then job_id, both descending), of one
  // shown state (0 = all), at most `limit`, strictly after `after`.
  virtual absl::StatusOr<std::vector<JobRecord>> ListJobs(int state, int limit, const std::optional<JobCursor>& after) = 0;
  struct ResultCursor {
    int64_t created_ms = 0;
    std::string cache_key;
  };
  // Results newest first (created_ms, then cache_key, descending).
  virtual absl::StatusOr<std::vector<StoredResult>> ListResults(int limit, const std::optional<ResultCursor>& after) = 0;
  // The oldest job with this cache key ("" when none): where a result's mesh
  // came from.
  virtual absl::StatusOr<std::string> OldestJobWithKey(const std::string& cache_key) = 0;
  // One result with its pin and times.
  virtual absl::StatusOr<std::optional<StoredResult>> GetStoredResult(const std::string& cache_key) = 0;
  // True when some result lists a blob with this hash (its manifest.json or
  // one of its maps).
  virtual absl::StatusOr<bool> IsResultBlob(const std::string& hash) = 0;
  // QUEUED or RUNNING jobs (not cancelled by their requester) of `owner`.
  virtual absl::StatusOr<int64_t> CountPendingOwnedBy(const std::string& owner) = 0;
  // RUNNING leaders whose lease is held by the token `lease_holder`.
  virtual absl::StatusOr<std::vector<JobRecord>> RunningLeasedBy(const std::string& lease_holder) = 0;

  // --- Shared between servers on one database (issue 15) ---
  // Fairness history: records that `client_id` was just served a lease
  // (a sequence number higher than every earlier one).
  virtual absl::Status NoteServed(const std::string& client_id) = 0;
  // The sequence number of each client's last lease (absent: never).
  virtual absl::StatusOr<std::map<std::string, int64_t>> LastServed() = 0;
  // True while this server is the one that runs farm-wide maintenance
  // (lease-expiry sweeps, store-cap eviction, retention): exactly one
  // server on a database at a time; another takes over when it dies. An
  // engine with one server per database answers true.
  virtual absl::StatusOr<bool> HoldMaintenanceLock() = 0;
  // `callback` runs (on any thread) whenever another server may have
  // changed a job, so waiters re-check at once; null stops it. Returns
  // once a running callback has finished. Engines with one server per
  // database have no one else to hear from.
  virtual void SetChangeCallback(std::function<void()> callback) {}

  // --- Serving speed (issue 18): batched LRU times, bounded job table ---
  // Sets last_used_ms of each listed result (cache key -> Unix ms) in one
  // transaction, so one sync covers a whole batch of cache hits. Keys with
  // no result are skipped.
  virtual absl::Status TouchResults(const std::map<std::string, int64_t>& last_used_ms) = 0;
  // Deletes at most `limit` SUCCEEDED, FAILED or CANCELLED jobs created
  // before `cutoff_ms`; returns how many. QUEUED and RUNNING rows stay
  // whatever their age.
  virtual absl::StatusOr<int64_t> DeleteFinishedJobsCreatedBefore(int64_t cutoff_ms, int limit) = 0;
  // True when other servers may write this database too. The scheduler
  // then keeps no results in memory (ResultCache): their purges and
  // evictions would not reach it. True unless an engine knows better.
  virtual bool SharedWithOtherServers() const { return true; }

  // --- Health, without the owner's serialisation (see the top) ---
  // OK when the database answers a trivial statement within about
  // `timeout_ms`; UNAVAILABLE saying why otherwise. Never waits for a
  // reconnect window. An embedded engine (a local file) answers OK.
  virtual absl::Status Probe(int timeout_ms) { return absl::OkStatus(); }
  // UNAVAILABLE while the database is known to be unreachable (a reconnect
  // or a Probe failed, and nothing has succeeded since), saying for how long
  // and why; OK otherwise. Costs no round trip: read-only views check it
  // first and answer at once.
  virtual absl::Status Outage() const { return absl::OkStatus(); }
  // How many outages have ended since the engine opened: the database
  // became reachable again after statements failed for want of it. While
  // it was unreachable no worker's heartbeat could be recorded, so the
  // lease sweep gives running leases one lease timeout after each before it
  // expires any. An embedded engine has no outages: 0.
  virtual uint64_t OutagesRecovered() const { return 0; }
  // What to add to this server's system clock to read the clock every
  // server on the database shares (lease deadlines and the sweep's "now"
  // must be on one clock, or a server whose clock runs ahead expires
  // everyone's leases). Measured by the engine as it talks to the
  // database; 0 for an engine with one server per database.
  virtual int64_t ClockOffsetMs() const { return 0; }
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_STORE_JOB_STORE_H_
