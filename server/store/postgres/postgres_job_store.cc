#include "server/store/postgres/postgres_job_store.h"

#include <libpq-fe.h>
#include <poll.h>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "impostor/v1/bake_service.pb.h"
#include "server/store/postgres/libpq_args.h"
#include "server/store/postgres/pg_migrations.h"

namespace impostor {
namespace {

// Schema migrations, version = index + 1; never edit a released one, append.
constexpr const char* kMigrations[] = {
    // 1 (issue 15): the schema of SQLite's version 2, in PostgreSQL types,
    // plus the NOTIFY trigger that wakes other replicas' waiters.
    R"sql(
CREATE TABLE jobs (
  job_id              TEXT PRIMARY KEY,
  seq                 BIGSERIAL,  -- insertion order (SQLite's rowid)
  cache_key           TEXT NOT NULL,
  state               INTEGER NOT NULL,
  created_ms          BIGINT NOT NULL,
  lease_id            TEXT NOT NULL DEFAULT '',
  lease_deadline_ms   BIGINT NOT NULL DEFAULT 0,
  worker_id           TEXT NOT NULL DEFAULT '',
  job                 BYTEA NOT NULL,  -- impostor.v1.Job without `result`
  request             BYTEA NOT NULL,  -- impostor.v1.SubmitBakeRequest, parameters normalised
  leader_job_id       TEXT NOT NULL DEFAULT '',
  requester_cancelled INTEGER NOT NULL DEFAULT 0,
  client_id           TEXT NOT NULL DEFAULT '',
  priority            INTEGER NOT NULL DEFAULT 0,
  request_id          TEXT NOT NULL DEFAULT '',
  lease_expiries      INTEGER NOT NULL DEFAULT 0,
  owner               TEXT NOT NULL DEFAULT '',
  lease_holder        TEXT NOT NULL DEFAULT '',
  row_version         BIGINT NOT NULL DEFAULT 0
);
CREATE INDEX jobs_by_state ON jobs (state, created_ms);
CREATE INDEX jobs_by_key ON jobs (cache_key, state);
CREATE INDEX jobs_by_leader ON jobs (leader_job_id, state);
CREATE INDEX jobs_by_client ON jobs (client_id, state);
CREATE INDEX jobs_by_priority ON jobs (state, leader_job_id, priority, client_id, created_ms);
CREATE UNIQUE INDEX jobs_by_request ON jobs (client_id, request_id) WHERE request_id != '';
CREATE INDEX jobs_by_worker ON jobs (worker_id, state);
CREATE INDEX jobs_by_holder ON jobs (lease_holder, state);
-- One active bake per cache key, whichever replica inserts first.
CREATE UNIQUE INDEX jobs_active_leader_key ON jobs (cache_key) WHERE leader_job_id = '' AND state IN (1, 2);
CREATE TABLE results (
  cache_key    TEXT PRIMARY KEY,
  manifest     BYTEA NOT NULL,
  created_ms   BIGINT NOT NULL,
  last_used_ms BIGINT NOT NULL DEFAULT 0,
  pinned       INTEGER NOT NULL DEFAULT 0
);
CREATE TABLE result_blobs (hash TEXT NOT NULL, cache_key TEXT NOT NULL, PRIMARY KEY (hash, cache_key));
CREATE TABLE client_served (client_id TEXT PRIMARY KEY, served_seq BIGINT NOT NULL);
CREATE SEQUENCE lease_sequence;
CREATE FUNCTION impostor_notify_jobs() RETURNS trigger AS $$
BEGIN
  PERFORM pg_notify('impostor_jobs', '');
  RETURN NULL;
END $$ LANGUAGE plpgsql;
CREATE TRIGGER jobs_changed AFTER INSERT OR UPDATE OR DELETE ON jobs
  FOR EACH STATEMENT EXECUTE FUNCTION impostor_notify_jobs();
)sql",
    // 2: the maintenance holder's heartbeat, so a hung holder can be
    // replaced (pg_maintenance_lock.h).
    kMaintenanceHolderTableSql,
};
constexpr int kSchemaVersion = static_cast<int>(std::size(kMigrations));

// The maintenance advisory lock's key (pg_advisory_lock's bigint
// namespace): arbitrary, fixed, distinct from pg_migrations.cc's.
constexpr int64_t kMaintenanceLockKey = 0x696d706f73746f73;  // "impostos"

constexpr const char* kJobColumns =
    "job_id, cache_key, state, created_ms, lease_id, lease_deadline_ms, worker_id, job, request, leader_job_id, "
    "requester_cancelled, client_id, priority, request_id, lease_expiries, owner, lease_holder, row_version";

absl::StatusOr<JobRecord> ReadJob(const PgRows& rows, int i) {
  JobRecord r;
  v1::SubmitBakeRequest request;
  if (!r.job.ParseFromString(rows.Bytes(i, 7)) || !request.ParseFromString(rows.Bytes(i, 8))) {
    return absl::DataLossError(absl::StrCat("job ", rows.Text(i, 0), ": stored record does not parse"));
  }
  r.mesh = request.mesh();
  r.parameters = request.parameters();
  r.gate = request.gate();
  r.required_tags.assign(request.required_tags().begin(), request.required_tags().end());
  r.lease_id = rows.Text(i, 4);
  r.lease_deadline_ms = rows.Int(i, 5);
  r.worker_id = rows.Text(i, 6);
  r.leader_job_id = rows.Text(i, 9);
  r.requester_cancelled = rows.Int(i, 10) != 0;
  r.client_id = rows.Text(i, 11);
  r.lease_priority = static_cast<int32_t>(rows.Int(i, 12));
  r.request_id = rows.Text(i, 13);
  r.lease_expiries = static_cast<int32_t>(rows.Int(i, 14));
  r.owner = rows.Text(i, 15);
  r.lease_holder = rows.Text(i, 16);
  r.row_version = rows.Int(i, 17);
  return r;
}

// $1..$17 in kJobColumns order (without row_version).
PgParams JobParams(const JobRecord& r) {
  v1::Job job = r.job;
  job.clear_result();  // results live in their own table, once per key
  v1::SubmitBakeRequest request;
  *request.mutable_mesh() = r.mesh;
  *request.mutable_parameters() = r.parameters;
  if (r.gate.has_min_iou() || r.gate.has_min_psnr_db()) *request.mutable_gate() = r.gate;
  for (const std::string& tag : r.required_tags) request.add_required_tags(tag);
  PgParams p;
  p.Text(r.job.job_id())
      .Text(r.job.cache_key())
      .Int(r.job.state())
      .Int(r.job.created_ms())
      .Text(r.lease_id)
      .Int(r.lease_deadline_ms)
      .Text(r.worker_id)
      .Bytes(job.SerializeAsString())
      .Bytes(request.SerializeAsString())
      .Text(r.leader_job_id)
      .Int(r.requester_cancelled ? 1 : 0)
      .Text(r.client_id)
      .Int(r.lease_priority)
      .Text(r.request_id)
      .Int(r.lease_expiries)
      .Text(r.owner)
      .Text(r.lease_holder);
  return p;
}

constexpr const char* kResultColumns = "cache_key, manifest, pinned, created_ms, last_used_ms";

absl::StatusOr<JobStore::StoredResult> ReadResult(const PgRows& rows, int i) {
  JobStore::StoredResult r;
  if (!r.manifest.ParseFromString(rows.Bytes(i, 1))) {
    return absl::DataLossError("result " + rows.Text(i, 0) + " does not parse");
  }
  r.pinned = rows.Int(i, 2) != 0;
  r.created_ms = rows.Int(i, 3);
  r.last_used_ms = rows.Int(i, 4);
  return r;
}

const std::string kQueued = std::to_string(v1::JOB_STATE_QUEUED);
const std::string kRunning = std::to_string(v1::JOB_STATE_RUNNING);

}  // namespace

int PostgresSchemaVersion() { return kSchemaVersion; }
int64_t PostgresMaintenanceLockKey() { return kMaintenanceLockKey; }

absl::StatusOr<std::unique_ptr<PostgresJobStore>> PostgresJobStore::Open(const Options& options) {
  auto pool = PgConnectionPool::Open({.url = options.url,
                                      .size = options.pool_size,
                                      .statement_timeout_ms = options.statement_timeout_ms,
                                      .reconnect_window_ms = options.reconnect_window_ms,
                                      .dead_link_seconds = options.dead_link_seconds});
  if (!pool.ok()) return pool.status();
  std::unique_ptr<PostgresJobStore> store(new PostgresJobStore(std::move(*pool), options));
  if (auto s = store->Migrate(); !s.ok()) return s;
  if (auto s = store->SampleClock(); !s.ok()) return s;
  // LISTEN before Open returns, so no change made after it is missed.
  auto conn = store->ListenConnection();
  if (!conn.ok()) return conn.status();
  store->listener_ = std::thread([s = store.get(), c = *conn] { s->Listen(c); });
  return store;
}

PostgresJobStore::PostgresJobStore(std::unique_ptr<PgConnectionPool> pool, const Options& options)
    : pool_(std::move(pool)),
      clock_(options.local_clock_ms, pool_->redacted_url()),
      maintenance_(pool_.get(), &clock_, kMaintenanceLockKey, options.maintenance_takeover_ms) {}

PostgresJobStore::~PostgresJobStore() {
  stop_ = true;
  if (listener_.joinable()) listener_.join();
}

absl::Status PostgresJobStore::SampleClock() {
  const int64_t sent = clock_.LocalNowMs();
  auto rows = pool_->Exec("read the database clock", absl::StrCat("SELECT ", kDatabaseClockMsSql));
  if (!rows.ok()) return rows.status();
  clock_.Note(sent, rows->Int(0, 0), clock_.LocalNowMs());
  return absl::OkStatus();
}

absl::Status PostgresJobStore::Migrate() {
  return ApplyPgMigrations(*pool_, {.component = "job store", .version_table = "schema_version", .scripts = kMigrations});
}

absl::StatusOr<std::optional<JobRecord>> PostgresJobStore::QueryOne(const std::string& what, const std::string& sql,
                                                                    const PgParams& params) {
  auto rows = pool_->Exec(what, sql, params);
  if (!rows.ok()) return rows.status();
  if (rows->size() == 0) return std::optional<JobRecord>();
  auto r = ReadJob(*rows, 0);
  if (!r.ok()) return r.status();
  return std::optional<JobRecord>(std::move(*r));
}

absl::StatusOr<std::vector<JobRecord>> PostgresJobStore::QueryMany(const std::string& what, const std::string& sql,
                                                                   const PgParams& params) {
  absl::StatusOr<PgRows> rows = pool_->Exec(what, sql, params);
  if (!rows.ok()) return rows.status();
  std::vector<JobRecord> out;
  for (int i = 0; i < rows->size(); ++i) {
    absl::StatusOr<JobRecord> r = ReadJob(*rows, i);
    if (!r.ok()) {
      if (SkipUnreadableJobRow(r.status())) continue;
      return r.status();
    }
    out.push_back(std::move(*r));
  }
  return out;
}

absl::Status PostgresJobStore::Insert(const JobRecord& record) {
  return pool_->Exec("insert job",
                     absl::StrCat("INSERT INTO jobs (", kJobColumns,
                                  ") VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14, $15, $16, "
                                  "$17, 0)"),
                     JobParams(record))
      .status();
}

absl::Status PostgresJobStore::Update(const JobRecord& record) {
  PgParams p = JobParams(record);
  p.Int(record.row_version);
  auto rows = pool_->Exec("update job",
                          "UPDATE jobs SET cache_key = $2, state = $3, created_ms = $4, lease_id = $5, "
                          "lease_deadline_ms = $6, worker_id = $7, job = $8, request = $9, leader_job_id = $10, "
                          "requester_cancelled = $11, client_id = $12, priority = $13, request_id = $14, "
                          "lease_expiries = $15, owner = $16, lease_holder = $17, row_version = $18 + 1 "
                          "WHERE job_id = $1 AND row_version = $18",
                          p);
  if (!rows.ok()) return rows.status();
  if (rows->changed() > 0) return absl::OkStatus();
  auto now = Get(record.job.job_id());
  if (!now.ok()) return now.status();
  if (!now->has_value()) return absl::NotFoundError(absl::StrCat("job ", record.job.job_id(), " not found"));
  return absl::AbortedError(absl::StrCat("job ", record.job.job_id(), " changed on another server since it was read (",
                                         "version ", record.row_version, ", now ", (*now)->row_version, "); retry"));
}

absl::StatusOr<std::optional<JobRecord>> PostgresJobStore::ClaimQueued(const std::vector<std::string>& job_ids,
                                                                       const LeaseGrant& grant) {
  std::optional<JobRecord> claimed;
  absl::Status s = pool_->Transaction([&](PgSession& db) -> absl::Status {
    claimed.reset();
    // The claim: one statement that locks the first candidate no other
    // transaction holds and that is still queued, and takes its lease. A
    // replica racing for the same row skips it (SKIP LOCKED) or, once we
    // commit, no longer sees it QUEUED.
    auto rows = db.Exec(
        "claim job",
        absl::StrCat("UPDATE jobs SET state = ", kRunning,
                     ", lease_id = $2, lease_deadline_ms = $3, worker_id = $4, lease_holder = $5, "
                     "row_version = row_version + 1 WHERE job_id = (SELECT job_id FROM jobs WHERE job_id = ANY($1::text[]) "
                     "AND state = ", kQueued, " AND leader_job_id = '' ORDER BY array_position($1::text[], job_id) "
                     "LIMIT 1 FOR UPDATE SKIP LOCKED) AND state = ", kQueued, " RETURNING ", kJobColumns),
        PgParams()
            .TextArray(job_ids)
            .Text(grant.lease_id)
            .Int(grant.lease_deadline_ms)
            .Text(grant.worker_id)
            .Text(grant.lease_holder));
    if (!rows.ok()) return rows.status();
    if (rows->size() == 0) return absl::OkStatus();
    auto r = ReadJob(*rows, 0);
    if (!r.ok()) return r.status();
    // The row is ours (locked, lease set): bring the stored Job message in
    // line (attempts, stage, progress) in the same transaction.
    ApplyLeaseGrant(*r, grant);
    auto w = db.Exec("claim job", "UPDATE jobs SET job = $1 WHERE job_id = $2 AND lease_id = $3",
                     PgParams().Bytes(r->job.SerializeAsString()).Text(r->job.job_id()).Text(grant.lease_id));
    if (!w.ok()) return w.status();
    claimed = std::move(*r);
    return absl::OkStatus();
  });
  if (!s.ok()) return s;
  return claimed;
}

absl::StatusOr<std::optional<JobRecord>> PostgresJobStore::Get(const std::string& job_id) {
  return QueryOne("get job", absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE job_id = $1"),
                  PgParams().Text(job_id));
}

absl::StatusOr<std::optional<JobRecord>> PostgresJobStore::OldestQueued() {
  return QueryOne("oldest queued",
                  absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE state = ", kQueued,
                               " AND leader_job_id = '' ORDER BY created_ms, seq LIMIT 1"),
                  PgParams());
}

absl::StatusOr<std::vector<JobRecord>> PostgresJobStore::QueueHeadsPerClient(
    const std::vector<std::string>& skip_job_ids) {
  // ANY of an empty array is false: nothing skipped.
  const std::string queued =
      absl::StrCat("state = ", kQueued, " AND leader_job_id = '' AND NOT (job_id = ANY($1::text[]))");
  return QueryMany("queue heads",
                   absl::StrCat("SELECT DISTINCT ON (client_id) ", kJobColumns, " FROM jobs WHERE ", queued,
                                " AND priority = (SELECT MAX(priority) FROM jobs WHERE ", queued,
                                ") ORDER BY client_id, created_ms, seq"),
                   PgParams().TextArray(skip_job_ids));
}

absl::StatusOr<std::map<std::string, int64_t>> PostgresJobStore::RunningPerClient() {
  auto rows = pool_->Exec("count running",
                          absl::StrCat("SELECT client_id, COUNT(*) FROM jobs WHERE state = ", kRunning,
                                       " AND leader_job_id = '' GROUP BY client_id"));
  if (!rows.ok()) return rows.status();
  std::map<std::string, int64_t> out;
  for (int i = 0; i < rows->size(); ++i) out[rows->Text(i, 0)] = rows->Int(i, 1);
  return out;
}

absl::StatusOr<std::vector<JobStore::RunningLease>> PostgresJobStore::RunningLeases() {
  auto rows = pool_->Exec("running leases", absl::StrCat("SELECT worker_id, client_id, owner FROM jobs WHERE state = ",
                                                        kRunning, " AND leader_job_id = ''"));
  if (!rows.ok()) return rows.status();
  std::vector<RunningLease> out;
  for (int i = 0; i < rows->size(); ++i) out.push_back({rows->Text(i, 0), rows->Text(i, 1), rows->Text(i, 2)});
  return out;
}

absl::StatusOr<std::vector<JobRecord>> PostgresJobStore::QueuedOfTeam(const std::string& team, int limit) {
  return QueryMany("queued of team",
                   absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE state = ", kQueued,
                                " AND leader_job_id = '' AND (owner = $1 OR client_id = $1) "
                                "ORDER BY priority DESC, created_ms, seq LIMIT $2"),
                   PgParams().Text(team).Int(limit));
}

absl::StatusOr<std::optional<JobRecord>> PostgresJobStore::ActiveWithKey(const std::string& cache_key) {
  return QueryOne("active with key",
                  absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE cache_key = $1 AND state IN (", kQueued, ", ",
                               kRunning, ") AND leader_job_id = '' ORDER BY created_ms LIMIT 1"),
                  PgParams().Text(cache_key));
}

absl::StatusOr<std::vector<JobRecord>> PostgresJobStore::ActiveFollowers(const std::string& leader_job_id) {
  return QueryMany("active followers",
                   absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE leader_job_id = $1 AND state IN (", kQueued,
                                ", ", kRunning, ")"),
                   PgParams().Text(leader_job_id));
}

absl::StatusOr<int64_t> PostgresJobStore::CountPending(const std::string& client_id) {
  const std::string base = absl::StrCat("SELECT COUNT(*) FROM jobs WHERE state IN (", kQueued, ", ", kRunning,
                                        ") AND requester_cancelled = 0");
  auto rows = client_id.empty() ? pool_->Exec("count pending", base)
                                : pool_->Exec("count pending", base + " AND client_id = $1", PgParams().Text(client_id));
  if (!rows.ok()) return rows.status();
  return rows->Int(0, 0);
}

absl::StatusOr<std::optional<JobRecord>> PostgresJobStore::FindByRequestId(const std::string& client_id,
                                                                           const std::string& request_id) {
  return QueryOne("find by request id",
                  absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE client_id = $1 AND request_id = $2"),
                  PgParams().Text(client_id).Text(request_id));
}

absl::StatusOr<std::vector<JobRecord>> PostgresJobStore::RunningOnWorker(const std::string& worker_id) {
  return QueryMany("running on worker",
                   absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE worker_id = $1 AND state = ", kRunning,
                                " AND leader_job_id = ''"),
                   PgParams().Text(worker_id));
}

absl::StatusOr<std::vector<JobRecord>> PostgresJobStore::FinishedLeadersWithWaitingFollowers(int limit) {
  // States: 3..5 SUCCEEDED, FAILED, CANCELLED; 1, 2 QUEUED, RUNNING. Asked
  // from the waiting followers' side (the live queue, few) so that the
  // engine can look leaders up by job_id instead of walking finished jobs.
  return QueryMany("finished leaders",
                   absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE leader_job_id = '' AND state IN (3, 4, 5) AND job_id IN "
                                "(SELECT leader_job_id FROM jobs WHERE state IN (1, 2) AND leader_job_id <> '') "
                                "LIMIT $1"),
                   PgParams().Int(limit));
}

absl::StatusOr<std::vector<JobRecord>> PostgresJobStore::ExpiredLeases(int64_t now_ms) {
  return QueryMany("expired leases",
                   absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE state = ", kRunning,
                                " AND lease_deadline_ms < $1"),
                   PgParams().Int(now_ms));
}

absl::Status PostgresJobStore::PutResult(const v1::Manifest& manifest, int64_t now_ms) {
  return pool_->Transaction([&](PgSession& db) -> absl::Status {
    auto r = db.Exec("insert result",
                     "INSERT INTO results (cache_key, manifest, created_ms, last_used_ms) VALUES ($1, $2, $3, $3) "
                     "ON CONFLICT (cache_key) DO UPDATE SET manifest = excluded.manifest, "
                     "last_used_ms = excluded.last_used_ms",
                     PgParams().Text(manifest.cache_key()).Bytes(manifest.SerializeAsString()).Int(now_ms));
    if (!r.ok()) return r.status();
    r = db.Exec("index result blobs", "DELETE FROM result_blobs WHERE cache_key = $1",
                PgParams().Text(manifest.cache_key()));
    if (!r.ok()) return r.status();
    std::vector<std::string> hashes = {manifest.manifest_json().hash()};
    for (const auto& map : manifest.maps()) hashes.push_back(map.digest().hash());
    for (const std::string& hash : hashes) {
      if (hash.empty()) continue;
      r = db.Exec("index result blobs", "INSERT INTO result_blobs (hash, cache_key) VALUES ($1, $2) ON CONFLICT DO NOTHING",
                  PgParams().Text(hash).Text(manifest.cache_key()));
      if (!r.ok()) return r.status();
    }
    return absl::OkStatus();
  });
}

absl::StatusOr<std::optional<v1::Manifest>> PostgresJobStore::GetResult(const std::string& cache_key) {
  auto rows = pool_->Exec("get result", "SELECT manifest FROM results WHERE cache_key = $1", PgParams().Text(cache_key));
  if (!rows.ok()) return rows.status();
  if (rows->size() == 0) return std::optional<v1::Manifest>();
  v1::Manifest m;
  if (!m.ParseFromString(rows->Bytes(0, 0))) {
    return absl::DataLossError("result " + cache_key + ": stored manifest does not parse");
  }
  return std::optional<v1::Manifest>(std::move(m));
}

absl::Status PostgresJobStore::DeleteResult(const std::string& cache_key) {
  return pool_->Transaction([&](PgSession& db) -> absl::Status {
    auto r = db.Exec("delete result", "DELETE FROM results WHERE cache_key = $1", PgParams().Text(cache_key));
    if (!r.ok()) return r.status();
    return db.Exec("delete result blobs", "DELETE FROM result_blobs WHERE cache_key = $1", PgParams().Text(cache_key))
        .status();
  });
}

absl::Status PostgresJobStore::TouchResult(const std::string& cache_key, int64_t now_ms) {
  return pool_->Exec("touch result", "UPDATE results SET last_used_ms = $2 WHERE cache_key = $1",
                     PgParams().Text(cache_key).Int(now_ms))
      .status();
}

absl::StatusOr<bool> PostgresJobStore::PinResult(const std::string& cache_key, bool pinned) {
  auto rows = pool_->Exec("pin result", "UPDATE results SET pinned = $2 WHERE cache_key = $1",
                          PgParams().Text(cache_key).Int(pinned ? 1 : 0));
  if (!rows.ok()) return rows.status();
  return rows->changed() > 0;
}

absl::StatusOr<std::vector<JobStore::StoredResult>> PostgresJobStore::ResultsByLastUse() {
  return ReadEachRow<StoredResult>(
      pool_->Exec("list results",
                  absl::StrCat("SELECT ", kResultColumns, " FROM results ORDER BY last_used_ms, created_ms")),
      ReadResult);
}

absl::StatusOr<std::vector<JobRecord>> PostgresJobStore::Pending() {
  return QueryMany("pending",
                   absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE state IN (", kQueued, ", ", kRunning, ")"),
                   PgParams());
}

absl::StatusOr<std::map<int, int64_t>> PostgresJobStore::CountByState() {
  auto rows = pool_->Exec("count by state", absl::StrCat("SELECT ", kShownStateSql, " AS shown, COUNT(*) FROM jobs GROUP BY shown"));
  if (!rows.ok()) return rows.status();
  std::map<int, int64_t> out;
  for (int i = 0; i < rows->size(); ++i) out[static_cast<int>(rows->Int(i, 0))] = rows->Int(i, 1);
  return out;
}

absl::StatusOr<std::vector<JobRecord>> PostgresJobStore::ListJobs(int state, int limit,
                                                                  const std::optional<JobCursor>& after) {
  PgParams p;
  std::string sql = absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE TRUE");
  if (state != 0) {
    p.Int(state);
    sql += absl::StrCat(" AND ", kShownStateSql, " = $", p.size());
  }
  if (after) {
    p.Int(after->created_ms).Text(after->job_id);
    sql += absl::StrCat(" AND (created_ms < $", p.size() - 1, " OR (created_ms = $", p.size() - 1, " AND job_id < $",
                        p.size(), "))");
  }
  p.Int(limit);
  sql += absl::StrCat(" ORDER BY created_ms DESC, job_id DESC LIMIT $", p.size());
  return QueryMany("list jobs", sql, p);
}

absl::StatusOr<std::vector<JobStore::StoredResult>> PostgresJobStore::ListResults(
    int limit, const std::optional<ResultCursor>& after) {
  PgParams p;
  std::string sql = absl::StrCat("SELECT ", kResultColumns, " FROM results");
  if (after) {
    p.Int(after->created_ms).Text(after->cache_key);
    sql += " WHERE created_ms < $1 OR (created_ms = $1 AND cache_key < $2)";
  }
  p.Int(limit);
  sql += absl::StrCat(" ORDER BY created_ms DESC, cache_key DESC LIMIT $", p.size());
  return ReadEachRow<StoredResult>(pool_->Exec("list results", sql, p), ReadResult);
}

absl::StatusOr<std::string> PostgresJobStore::OldestJobWithKey(const std::string& cache_key) {
  auto rows = pool_->Exec("job by key", "SELECT job_id FROM jobs WHERE cache_key = $1 ORDER BY created_ms, seq LIMIT 1",
                          PgParams().Text(cache_key));
  if (!rows.ok()) return rows.status();
  if (rows->size() == 0) return std::string();
  return rows->Text(0, 0);
}

absl::StatusOr<std::optional<JobStore::StoredResult>> PostgresJobStore::GetStoredResult(const std::string& cache_key) {
  auto rows = pool_->Exec("get result", absl::StrCat("SELECT ", kResultColumns, " FROM results WHERE cache_key = $1"),
                          PgParams().Text(cache_key));
  if (!rows.ok()) return rows.status();
  if (rows->size() == 0) return std::optional<StoredResult>();
  auto r = ReadResult(*rows, 0);
  if (!r.ok()) return r.status();
  return std::optional<StoredResult>(std::move(*r));
}

absl::StatusOr<bool> PostgresJobStore::IsResultBlob(const std::string& hash) {
  auto rows = pool_->Exec("query result blobs", "SELECT 1 FROM result_blobs WHERE hash = $1 LIMIT 1",
                          PgParams().Text(hash));
  if (!rows.ok()) return rows.status();
  return rows->size() > 0;
}

absl::StatusOr<int64_t> PostgresJobStore::CountPendingOwnedBy(const std::string& owner) {
  auto rows = pool_->Exec("count pending of owner",
                          absl::StrCat("SELECT COUNT(*) FROM jobs WHERE state IN (", kQueued, ", ", kRunning,
                                       ") AND requester_cancelled = 0 AND owner = $1"),
                          PgParams().Text(owner));
  if (!rows.ok()) return rows.status();
  return rows->Int(0, 0);
}

absl::StatusOr<std::vector<JobRecord>> PostgresJobStore::RunningLeasedBy(const std::string& lease_holder) {
  return QueryMany("running leased by",
                   absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE lease_holder = $1 AND state = ", kRunning,
                                " AND leader_job_id = ''"),
                   PgParams().Text(lease_holder));
}

absl::Status PostgresJobStore::NoteServed(const std::string& client_id) {
  return pool_->Exec("note served",
                     "INSERT INTO client_served (client_id, served_seq) VALUES ($1, nextval('lease_sequence')) "
                     "ON CONFLICT (client_id) DO UPDATE SET served_seq = excluded.served_seq",
                     PgParams().Text(client_id))
      .status();
}

absl::StatusOr<std::map<std::string, int64_t>> PostgresJobStore::LastServed() {
  auto rows = pool_->Exec("read served", "SELECT client_id, served_seq FROM client_served");
  if (!rows.ok()) return rows.status();
  std::map<std::string, int64_t> out;
  for (int i = 0; i < rows->size(); ++i) out[rows->Text(i, 0)] = rows->Int(i, 1);
  return out;
}

absl::StatusOr<bool> PostgresJobStore::HoldMaintenanceLock() { return maintenance_.Hold(); }

void PostgresJobStore::SetChangeCallback(std::function<void()> callback) {
  std::lock_guard lock(callback_mu_);
  callback_ = std::move(callback);
}

absl::StatusOr<pg_conn*> PostgresJobStore::ListenConnection() {
  auto c = pool_->Connect();
  if (!c.ok()) return c.status();
  PGresult* r = PQexec(*c, "LISTEN impostor_jobs");
  const bool ok = r && PQresultStatus(r) == PGRES_COMMAND_OK;
  PQclear(r);
  if (ok) return *c;
  const std::string why = LibpqMessageLine(PQerrorMessage(*c));
  PQfinish(*c);
  return absl::UnavailableError(absl::StrCat("postgresql listen (", pool_->redacted_url(), "): ", why));
}

void PostgresJobStore::Listen(pg_conn* conn) {
  auto wake = [&] {
    std::lock_guard lock(callback_mu_);
    if (callback_) callback_();
  };
  while (!stop_) {
    if (conn == nullptr || PQstatus(conn) != CONNECTION_OK) {
      if (conn != nullptr) PQfinish(conn);
      conn = nullptr;
      if (auto c = ListenConnection(); c.ok()) {
        conn = *c;
        // Whatever changed while we were not listening: look again.
        wake();
      }
      if (conn == nullptr) {
        // Waiters fall back to their bounded polling meanwhile.
        for (int i = 0; i < 10 && !stop_; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
        continue;
      }
    }
    // Wake at least every 200 ms to notice stop_.
    pollfd pfd{.fd = PQsocket(conn), .events = POLLIN, .revents = 0};
    if (poll(&pfd, 1, 200) <= 0) continue;
    if (PQconsumeInput(conn) == 0) {
      PQfinish(conn);
      conn = nullptr;
      continue;
    }
    bool any = false;
    while (PGnotify* n = PQnotifies(conn)) {
      any = true;
      PQfreemem(n);
    }
    if (any) wake();
  }
  if (conn != nullptr) PQfinish(conn);
}

// --- Serving speed (issue 18) ---

absl::Status PostgresJobStore::TouchResults(const std::map<std::string, int64_t>& last_used_ms) {
  if (last_used_ms.empty()) return absl::OkStatus();
  return pool_->Transaction([&](PgSession& db) -> absl::Status {
    for (const auto& [key, ms] : last_used_ms) {
      auto r = db.Exec("touch results", "UPDATE results SET last_used_ms = GREATEST(last_used_ms, $2) WHERE cache_key = $1",
                       PgParams().Text(key).Int(ms));
      if (!r.ok()) return r.status();
    }
    return absl::OkStatus();
  });
}

absl::StatusOr<int64_t> PostgresJobStore::DeleteFinishedJobsCreatedBefore(int64_t cutoff_ms, int limit) {
  auto rows = pool_->Exec("delete finished jobs",
                          absl::StrCat("DELETE FROM jobs WHERE job_id IN (SELECT job_id FROM jobs WHERE state IN (",
                                       int{v1::JOB_STATE_SUCCEEDED}, ", ", int{v1::JOB_STATE_FAILED}, ", ",
                                       int{v1::JOB_STATE_CANCELLED}, ") AND created_ms < $1 LIMIT $2)"),
                          PgParams().Int(cutoff_ms).Int(limit));
  if (!rows.ok()) return rows.status();
  return static_cast<int64_t>(rows->changed());
}

}  // namespace impostor
