// Durable job and result records in an embedded SQLite database
// (DIR/jobs.sqlite3, WAL journal, synchronous=FULL), so a server restart
// loses no accepted job and no baked result.
//
// Plain persistence: no scheduling policy lives here (see BakeScheduler).
// Thread-safety: not thread-safe; the owner serialises calls (BakeScheduler
// holds its mutex around every call).
#ifndef IMPOSTOR_SERVER_JOB_STORE_H_
#define IMPOSTOR_SERVER_JOB_STORE_H_

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "impostor/v1/types.pb.h"
#include "impostor/v1/worker_service.pb.h"

struct sqlite3;

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
};

class JobStore {
 public:
  // Opens or creates the database. INTERNAL with SQLite's message on failure.
  static absl::StatusOr<std::unique_ptr<JobStore>> Open(const std::filesystem::path& file);
  ~JobStore();

  absl::Status Insert(const JobRecord& record);
  // Writes every field of an existing job. NOT_FOUND if absent.
  absl::Status Update(const JobRecord& record);
  absl::StatusOr<std::optional<JobRecord>> Get(const std::string& job_id);
  // The oldest QUEUED leader.
  absl::StatusOr<std::optional<JobRecord>> OldestQueued();
  // For the highest lease priority among QUEUED leaders: the oldest QUEUED
  // leader of each client at that priority (one per client, any order).
  // Empty when nothing is queued.
  absl::StatusOr<std::vector<JobRecord>> QueueHeadsPerClient();
  // RUNNING leaders per client_id (clients with none are absent).
  absl::StatusOr<std::map<std::string, int64_t>> RunningPerClient();
  // A QUEUED or RUNNING leader with this cache key.
  absl::StatusOr<std::optional<JobRecord>> ActiveWithKey(const std::string& cache_key);
  // Followers of `leader_job_id` that are still QUEUED or RUNNING.
  absl::StatusOr<std::vector<JobRecord>> ActiveFollowers(const std::string& leader_job_id);
  // QUEUED or RUNNING rows, of one client or (client_id empty) of everyone.
  absl::StatusOr<int64_t> CountPending(const std::string& client_id);
  // The job a submit with this (client_id, request_id) created, if any.
  absl::StatusOr<std::optional<JobRecord>> FindByRequestId(const std::string& client_id,
                                                           const std::string& request_id);
  // RUNNING leaders leased to `worker_id`.
  absl::StatusOr<std::vector<JobRecord>> RunningOnWorker(const std::string& worker_id);
  // RUNNING jobs whose lease deadline is before `now_ms`.
  absl::StatusOr<std::vector<JobRecord>> ExpiredLeases(int64_t now_ms);

  absl::Status PutResult(const v1::Manifest& manifest, int64_t now_ms);
  absl::StatusOr<std::optional<v1::Manifest>> GetResult(const std::string& cache_key);
  absl::Status DeleteResult(const std::string& cache_key);
  // Records a use of the result (cache hit, GetResult) for LRU eviction.
  absl::Status TouchResult(const std::string& cache_key, int64_t now_ms);
  // Sets or clears the pin; false when no result has that key.
  absl::StatusOr<bool> PinResult(const std::string& cache_key, bool pinned);
  struct StoredResult {
    v1::Manifest manifest;
    bool pinned = false;
    int64_t created_ms = 0;    // when it was first stored (Unix ms)
    int64_t last_used_ms = 0;  // last cache hit or fetch (Unix ms)
    std::string source_job_id;  // GetStoredResult only: OldestJobWithKey
  };
  // Every result, least recently used first.
  absl::StatusOr<std::vector<StoredResult>> ResultsByLastUse();
  // Every QUEUED or RUNNING job.
  absl::StatusOr<std::vector<JobRecord>> Pending();

  // --- Read-only listings for the HTTP adapter (server/http/) ---
  // Rows per `state` column value.
  absl::StatusOr<std::map<int, int64_t>> CountByState();
  // Position in a newest-first listing: the last row of the previous page.
  struct JobCursor {
    int64_t created_ms = 0;
    std::string job_id;
  };
  // Jobs newest first (created_ms, then job_id, both descending), of one
  // state (0 = all), at most `limit`, strictly after `after`.
  absl::StatusOr<std::vector<JobRecord>> ListJobs(int state, int limit, const std::optional<JobCursor>& after);
  struct ResultCursor {
    int64_t created_ms = 0;
    std::string cache_key;
  };
  // Results newest first (created_ms, then cache_key, descending).
  absl::StatusOr<std::vector<StoredResult>> ListResults(int limit, const std::optional<ResultCursor>& after);
  // The oldest job with this cache key ("" when none): where a result's mesh
  // came from.
  absl::StatusOr<std::string> OldestJobWithKey(const std::string& cache_key);
  // One result with its pin and times.
  absl::StatusOr<std::optional<StoredResult>> GetStoredResult(const std::string& cache_key);
  // True when some result lists a blob with this hash (its manifest.json or
  // one of its maps).
  absl::StatusOr<bool> IsResultBlob(const std::string& hash);
  // QUEUED or RUNNING jobs (not cancelled by their requester) of `owner`.
  absl::StatusOr<int64_t> CountPendingOwnedBy(const std::string& owner);
  // RUNNING leaders whose lease is held by the token `lease_holder`.
  absl::StatusOr<std::vector<JobRecord>> RunningLeasedBy(const std::string& lease_holder);

  // --- Serving speed (issue 18): batched LRU times, bounded job table ---
  // Sets last_used_ms of each listed result (cache key -> Unix ms) in one
  // transaction, so one sync covers a whole batch of cache hits. Keys with
  // no result are skipped.
  absl::Status TouchResults(const std::map<std::string, int64_t>& last_used_ms);
  // Deletes at most `limit` SUCCEEDED, FAILED or CANCELLED jobs created
  // before `cutoff_ms`; returns how many. QUEUED and RUNNING rows stay
  // whatever their age.
  absl::StatusOr<int64_t> DeleteFinishedJobsCreatedBefore(int64_t cutoff_ms, int limit);

 private:
  explicit JobStore(sqlite3* db) : db_(db) {}
  // Rewrites the result_blobs rows of one result.
  absl::Status IndexResultBlobs(const v1::Manifest& manifest);
  // A database from before result_blobs: index every result once.
  absl::Status BackfillResultBlobs();
  sqlite3* db_;
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_JOB_STORE_H_
