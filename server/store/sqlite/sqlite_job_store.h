// The embedded engine: JobStore on one SQLite file (DIR/jobs.sqlite3, WAL
// journal, synchronous=FULL), so a server restart loses no accepted job and
// no baked result. One server process owns the file.
//
// Thread-safety: not thread-safe; the owner serialises calls.
#ifndef IMPOSTOR_SERVER_STORE_SQLITE_SQLITE_JOB_STORE_H_
#define IMPOSTOR_SERVER_STORE_SQLITE_SQLITE_JOB_STORE_H_

#include <filesystem>
#include <memory>

#include "server/store/job_store.h"
#include "server/store/sqlite/sqlite_open.h"

struct sqlite3;

namespace impostor {

class SqliteJobStore : public JobStore {
 public:
  // Opens or creates the database and brings its schema up to date.
  // INTERNAL with SQLite's message on failure.
  static absl::StatusOr<std::unique_ptr<SqliteJobStore>> Open(const std::filesystem::path& file);
  ~SqliteJobStore() override;

  absl::Status Insert(const JobRecord& record) override;
  absl::Status Update(const JobRecord& record) override;
  absl::StatusOr<std::optional<JobRecord>> Get(const std::string& job_id) override;
  absl::StatusOr<std::optional<JobRecord>> OldestQueued() override;
  absl::StatusOr<std::vector<JobRecord>> QueueHeadsPerClient(const std::vector<std::string>& skip_job_ids) override;
  absl::StatusOr<std::map<std::string, int64_t>> RunningPerClient() override;
  absl::StatusOr<std::vector<RunningLease>> RunningLeases() override;
  absl::StatusOr<std::vector<JobRecord>> QueuedOfTeam(const std::string& team, int limit) override;
  absl::StatusOr<std::optional<JobRecord>> ActiveWithKey(const std::string& cache_key) override;
  absl::StatusOr<std::vector<JobRecord>> ActiveFollowers(const std::string& leader_job_id) override;
  absl::StatusOr<int64_t> CountPending(const std::string& client_id) override;
  absl::StatusOr<std::optional<JobRecord>> FindByRequestId(const std::string& client_id, const std::string& request_id) override;
  absl::StatusOr<std::vector<JobRecord>> RunningOnWorker(const std::string& worker_id) override;
  absl::StatusOr<std::vector<JobRecord>> ExpiredLeases(int64_t now_ms) override;
  absl::StatusOr<std::vector<JobRecord>> FinishedLeadersWithWaitingFollowers(int limit) override;
  absl::Status PutResult(const v1::Manifest& manifest, int64_t now_ms) override;
  absl::StatusOr<std::optional<v1::Manifest>> GetResult(const std::string& cache_key) override;
  absl::Status DeleteResult(const std::string& cache_key) override;
  absl::Status TouchResult(const std::string& cache_key, int64_t now_ms) override;
  absl::StatusOr<bool> PinResult(const std::string& cache_key, bool pinned) override;
  absl::StatusOr<std::vector<StoredResult>> ResultsByLastUse() override;
  absl::StatusOr<std::vector<JobRecord>> Pending() override;
  absl::StatusOr<std::map<int, int64_t>> CountByState() override;
  absl::StatusOr<std::vector<JobRecord>> ListJobs(int state, int limit, const std::optional<JobCursor>& after) override;
  absl::StatusOr<std::vector<StoredResult>> ListResults(int limit, const std::optional<ResultCursor>& after) override;
  absl::StatusOr<std::string> OldestJobWithKey(const std::string& cache_key) override;
  absl::StatusOr<std::optional<StoredResult>> GetStoredResult(const std::string& cache_key) override;
  absl::StatusOr<bool> IsResultBlob(const std::string& hash) override;
  absl::StatusOr<int64_t> CountPendingOwnedBy(const std::string& owner) override;
  absl::StatusOr<std::vector<JobRecord>> RunningLeasedBy(const std::string& lease_holder) override;
  absl::StatusOr<std::optional<JobRecord>> ClaimQueued(const std::vector<std::string>& job_ids,
                                                       const LeaseGrant& grant) override;
  absl::Status NoteServed(const std::string& client_id) override;
  absl::StatusOr<std::map<std::string, int64_t>> LastServed() override;
  // Serving speed (issue 18).
  absl::Status TouchResults(const std::map<std::string, int64_t>& last_used_ms) override;
  absl::StatusOr<int64_t> DeleteFinishedJobsCreatedBefore(int64_t cutoff_ms, int limit) override;
  // One server per SQLite database: results may be kept in memory.
  bool SharedWithOtherServers() const override { return false; }
  // One server per file: always the maintainer.
  absl::StatusOr<bool> HoldMaintenanceLock() override { return true; }

 private:
  // Applies the versioned migrations past the stored schema_version.
  absl::Status MigrateVersions(const std::filesystem::path& file);
  explicit SqliteJobStore(sqlite3* db) : db_(db) {}
  // Rewrites the result_blobs rows of one result.
  absl::Status IndexResultBlobs(const v1::Manifest& manifest);
  // A database from before result_blobs: index every result once.
  absl::Status BackfillResultBlobs();
  sqlite3* db_;
  // FindByRequestId's statement, prepared once and reset after each use:
  // every cache hit with a request_id (the CLI always sends one) asks it
  // under the scheduler's lock, and parsing it each time was most of that
  // lock's hold time.
  std::unique_ptr<SqliteStatement> find_by_request_id_;
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_STORE_SQLITE_SQLITE_JOB_STORE_H_
