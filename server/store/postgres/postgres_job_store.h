// The shared engine: JobStore on PostgreSQL, for any number of server
// replicas on one database (issue 15).
//
// - Schema: versioned migrations (schema_version), applied at Open under an
//   advisory lock so replicas starting together migrate once; a database
//   newer than this binary is refused (FAILED_PRECONDITION).
// - Claims: ClaimQueued is one guarded statement, UPDATE ... WHERE job_id =
//   (SELECT ... FOR UPDATE SKIP LOCKED LIMIT 1) RETURNING ..., so two
//   replicas never lease one job; every Update is compare-and-swap on
//   row_version; one active bake per cache key is a partial unique index.
// - Wake-ups: a trigger NOTIFYs `impostor_jobs` on every job change; a
//   listener thread on its own connection runs the change callback.
// - Maintenance: HoldMaintenanceLock holds a session advisory lock on its
//   own connection and renews a heartbeat row each sweep; when that replica
//   dies its session ends, and when it hangs another replica ends its
//   session after `maintenance_takeover_ms` (pg_maintenance_lock.h).
// - Time: ClockOffsetMs puts lease deadlines and sweeps on the database's
//   clock, measured each sweep (pg_clock_offset.h); OutagesRecovered counts
//   the database coming back after an outage (the sweep's grace).
// - Connections: a pool with a statement timeout and reconnects
//   (pg_connection_pool.h); errors name the URL without its password.
//
// Thread-safety: thread-safe (the pool serialises per connection); the
// scheduler still serialises its calls.
#ifndef IMPOSTOR_SERVER_STORE_POSTGRES_POSTGRES_JOB_STORE_H_
#define IMPOSTOR_SERVER_STORE_POSTGRES_POSTGRES_JOB_STORE_H_

#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "server/store/job_store.h"
#include "server/store/postgres/pg_clock_offset.h"
#include "server/store/postgres/pg_connection_pool.h"
#include "server/store/postgres/pg_maintenance_lock.h"

namespace impostor {

// The schema version this binary writes (see kMigrations in the .cc).
int PostgresSchemaVersion();
// The advisory lock key HoldMaintenanceLock takes (for operators and tests:
// `SELECT pid FROM pg_locks WHERE locktype = 'advisory'`).
int64_t PostgresMaintenanceLockKey();

class PostgresJobStore : public JobStore {
 public:
  struct Options {
    std::string url;
    int pool_size = 8;
    int statement_timeout_ms = 10'000;
    int64_t reconnect_window_ms = 30'000;
    int dead_link_seconds = kDefaultDeadLinkSeconds;  // PgConnectionPool::Options
    // A maintenance holder whose heartbeat is older than this (on the
    // database's clock) is taken to have hung: another replica ends its
    // session and takes the role (pg_maintenance_lock.h). More than a sweep
    // can take: default 30 s (three statement timeouts); range 2 s .. 1 h.
    int64_t maintenance_takeover_ms = 30'000;
    // This server's clock, Unix ms; null = the system clock. Test-only: a
    // skewed clock, as a host's wrong time would give (pg_clock_offset.h).
    std::function<int64_t()> local_clock_ms = nullptr;
  };
  // Connects, migrates and starts the listener. UNAVAILABLE naming the
  // redacted URL when the database cannot be reached; FAILED_PRECONDITION
  // when its schema is newer than this binary.
  static absl::StatusOr<std::unique_ptr<PostgresJobStore>> Open(const Options& options);
  ~PostgresJobStore() override;

  absl::Status Insert(const JobRecord& record) override;
  absl::Status Update(const JobRecord& record) override;
  absl::StatusOr<std::optional<JobRecord>> ClaimQueued(const std::vector<std::string>& job_ids,
                                                       const LeaseGrant& grant) override;
  absl::StatusOr<std::optional<JobRecord>> Get(const std::string& job_id) override;
  absl::StatusOr<std::optional<JobRecord>> OldestQueued() override;
  absl::StatusOr<std::vector<JobRecord>> QueueHeadsPerClient(const std::vector<std::string>& skip_job_ids) override;
  absl::StatusOr<std::map<std::string, int64_t>> RunningPerClient() override;
  absl::StatusOr<std::vector<RunningLease>> RunningLeases() override;
  absl::StatusOr<std::vector<JobRecord>> QueuedOfTeam(const std::string& team, int limit) override;
  absl::StatusOr<std::optional<JobRecord>> ActiveWithKey(const std::string& cache_key) override;
  absl::StatusOr<std::vector<JobRecord>> ActiveFollowers(const std::string& leader_job_id) override;
  absl::StatusOr<int64_t> CountPending(const std::string& client_id) override;
  absl::StatusOr<std::optional<JobRecord>> FindByRequestId(const std::string& client_id,
                                                           const std::string& request_id) override;
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
  absl::StatusOr<std::vector<JobRecord>> ListJobs(int state, int limit,
                                                  const std::optional<JobCursor>& after) override;
  absl::StatusOr<std::vector<StoredResult>> ListResults(int limit, const std::optional<ResultCursor>& after) override;
  absl::StatusOr<std::string> OldestJobWithKey(const std::string& cache_key) override;
  absl::StatusOr<std::optional<StoredResult>> GetStoredResult(const std::string& cache_key) override;
  absl::StatusOr<bool> IsResultBlob(const std::string& hash) override;
  absl::StatusOr<int64_t> CountPendingOwnedBy(const std::string& owner) override;
  absl::StatusOr<std::vector<JobRecord>> RunningLeasedBy(const std::string& lease_holder) override;
  absl::Status NoteServed(const std::string& client_id) override;
  absl::StatusOr<std::map<std::string, int64_t>> LastServed() override;
  // Serving speed (issue 18).
  absl::Status TouchResults(const std::map<std::string, int64_t>& last_used_ms) override;
  absl::StatusOr<int64_t> DeleteFinishedJobsCreatedBefore(int64_t cutoff_ms, int limit) override;
  // Replicas share the database: no results in memory (issue 18's ResultCache).
  bool SharedWithOtherServers() const override { return true; }
  absl::StatusOr<bool> HoldMaintenanceLock() override;
  void SetChangeCallback(std::function<void()> callback) override;
  absl::Status Probe(int timeout_ms) override { return pool_->Probe(timeout_ms); }
  absl::Status Outage() const override { return pool_->Outage(); }
  uint64_t OutagesRecovered() const override { return pool_->OutagesRecovered(); }
  int64_t ClockOffsetMs() const override { return clock_.offset_ms(); }

 private:
  PostgresJobStore(std::unique_ptr<PgConnectionPool> pool, const Options& options);
  absl::Status Migrate();
  absl::StatusOr<std::optional<JobRecord>> QueryOne(const std::string& what, const std::string& sql,
                                                    const PgParams& params);
  absl::StatusOr<std::vector<JobRecord>> QueryMany(const std::string& what, const std::string& sql,
                                                   const PgParams& params);
  // A new connection that has run LISTEN impostor_jobs.
  absl::StatusOr<pg_conn*> ListenConnection();
  void Listen(pg_conn* conn);  // the listener thread's body; owns `conn`

  // Measures the offset once, at Open (later, each sweep samples it).
  absl::Status SampleClock();

  std::unique_ptr<PgConnectionPool> pool_;
  PgClockOffset clock_;
  PgMaintenanceLock maintenance_;

  std::mutex callback_mu_;
  std::function<void()> callback_;
  std::atomic<bool> stop_{false};
  std::thread listener_;
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_STORE_POSTGRES_POSTGRES_JOB_STORE_H_
