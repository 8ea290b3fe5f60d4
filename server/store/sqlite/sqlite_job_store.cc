#include "server/store/sqlite/sqlite_job_store.h"

#include <sqlite3.h>

#include "absl/cleanup/cleanup.h"
#include "absl/strings/str_cat.h"
#include "server/store/sqlite/sqlite_open.h"
#include "impostor/v1/bake_service.pb.h"

namespace impostor {
namespace {

constexpr const char* kSchema = R"sql(
PRAGMA journal_mode = WAL;
PRAGMA synchronous = FULL;
CREATE TABLE IF NOT EXISTS jobs (
  job_id            TEXT PRIMARY KEY,
  cache_key         TEXT NOT NULL,
  state             INTEGER NOT NULL,
  created_ms        INTEGER NOT NULL,
  lease_id          TEXT NOT NULL DEFAULT '',
  lease_deadline_ms INTEGER NOT NULL DEFAULT 0,
  worker_id         TEXT NOT NULL DEFAULT '',
  job               BLOB NOT NULL,  -- impostor.v1.Job without `result`
  request           BLOB NOT NULL,  -- impostor.v1.SubmitBakeRequest, parameters normalised
  leader_job_id     TEXT NOT NULL DEFAULT '',  -- '' for leaders (leased units of work)
  requester_cancelled INTEGER NOT NULL DEFAULT 0,
  client_id         TEXT NOT NULL DEFAULT ''
);
CREATE INDEX IF NOT EXISTS jobs_by_state ON jobs (state, created_ms);
CREATE INDEX IF NOT EXISTS jobs_by_key ON jobs (cache_key, state);
CREATE INDEX IF NOT EXISTS jobs_by_leader ON jobs (leader_job_id, state);
CREATE INDEX IF NOT EXISTS jobs_by_client ON jobs (client_id, state);
CREATE TABLE IF NOT EXISTS results (
  cache_key    TEXT PRIMARY KEY,
  manifest     BLOB NOT NULL,  -- impostor.v1.Manifest
  created_ms   INTEGER NOT NULL,
  last_used_ms INTEGER NOT NULL DEFAULT 0,  -- for least-recently-used eviction
  pinned       INTEGER NOT NULL DEFAULT 0   -- never evicted while 1
);
)sql";

// Columns added after the first release, each with the statement that adds
// it to an older database (SQLite's ALTER TABLE keeps existing rows, filled
// with the default). Applied in order at Open.
struct Migration {
  const char* column;
  const char* sql;
};
constexpr Migration kMigrations[] = {
    {"priority", "ALTER TABLE jobs ADD COLUMN priority INTEGER NOT NULL DEFAULT 0"},
    {"request_id", "ALTER TABLE jobs ADD COLUMN request_id TEXT NOT NULL DEFAULT ''"},
    {"lease_expiries", "ALTER TABLE jobs ADD COLUMN lease_expiries INTEGER NOT NULL DEFAULT 0"},
    // Issue 14: the token names of the submitter and of the worker holding
    // the lease ('' for jobs from before tokens, or with --auth none).
    {"owner", "ALTER TABLE jobs ADD COLUMN owner TEXT NOT NULL DEFAULT ''"},
    {"lease_holder", "ALTER TABLE jobs ADD COLUMN lease_holder TEXT NOT NULL DEFAULT ''"},
};
// Indexes over migrated columns: created after the migrations.
constexpr const char* kLateIndexes =
    "CREATE INDEX IF NOT EXISTS jobs_by_priority ON jobs (state, leader_job_id, priority, client_id, created_ms);"
    // One job per (requester, request id): a retried submit finds it, and a
    // second insert could only be a scheduler bug.
    "CREATE UNIQUE INDEX IF NOT EXISTS jobs_by_request ON jobs (client_id, request_id) WHERE request_id != '';"
    "CREATE INDEX IF NOT EXISTS jobs_by_worker ON jobs (worker_id, state);"
    "CREATE INDEX IF NOT EXISTS jobs_by_holder ON jobs (lease_holder, state);"
    // Which blobs belong to a result (its manifest.json and maps): who may
    // read a blob depends on it (access_policy.h). Filled by PutResult;
    // an older database is filled from its results at Open.
    "CREATE TABLE IF NOT EXISTS result_blobs (hash TEXT NOT NULL, cache_key TEXT NOT NULL, "
    "PRIMARY KEY (hash, cache_key));";

// Versioned migrations (table schema_version), applied in order at Open
// after the column migrations above (which bring any older database to
// version 1). A database whose version is above kSchemaVersion was written
// by a newer server: Open refuses it rather than guess.
constexpr const char* kVersionedMigrations[] = {
    // 2 (issue 15): compare-and-swap updates, one active bake per cache key
    // as a constraint, fairness history that survives restarts.
    "ALTER TABLE jobs ADD COLUMN row_version INTEGER NOT NULL DEFAULT 0;"
    "CREATE UNIQUE INDEX jobs_active_leader_key ON jobs (cache_key) WHERE leader_job_id = '' AND state IN (1, 2);"
    "CREATE TABLE client_served (client_id TEXT PRIMARY KEY, served_seq INTEGER NOT NULL);",
};
constexpr int kSchemaVersion = 1 + static_cast<int>(std::size(kVersionedMigrations));

constexpr const char* kJobColumns =
    "job_id, cache_key, state, created_ms, lease_id, lease_deadline_ms, worker_id, job, request, leader_job_id, "
    "requester_cancelled, client_id, priority, request_id, lease_expiries, owner, lease_holder, row_version";

// Every statement's errors say "sqlite <what>: ..." (disk full included,
// sqlite_open.h).
class Statement : public SqliteStatement {
 public:
  Statement(sqlite3* db, const char* sql) : SqliteStatement(db, sql, "sqlite") {}
};

absl::StatusOr<JobRecord> ReadJob(const SqliteStatement& st) {
  JobRecord r;
  v1::SubmitBakeRequest request;
  if (!r.job.ParseFromString(st.Blob(7)) || !request.ParseFromString(st.Blob(8))) {
    return absl::DataLossError(absl::StrCat("job ", st.Text(0), ": stored record does not parse"));
  }
  r.mesh = request.mesh();
  r.parameters = request.parameters();
  r.lease_id = st.Text(4);
  r.lease_deadline_ms = st.Int(5);
  r.worker_id = st.Text(6);
  r.leader_job_id = st.Text(9);
  r.requester_cancelled = st.Int(10) != 0;
  r.client_id = st.Text(11);
  r.lease_priority = static_cast<int32_t>(st.Int(12));
  r.gate = request.gate();
  r.required_tags.assign(request.required_tags().begin(), request.required_tags().end());
  r.request_id = st.Text(13);
  r.lease_expiries = static_cast<int32_t>(st.Int(14));
  r.owner = st.Text(15);
  r.lease_holder = st.Text(16);
  r.row_version = st.Int(17);
  return r;
}

// Runs a prepared, bound statement for at most one job row.
absl::StatusOr<std::optional<JobRecord>> StepOne(SqliteStatement& st) {
  const int rc = st.Step();
  if (rc == SQLITE_DONE) return std::optional<JobRecord>();
  if (rc != SQLITE_ROW) return st.Error("query");
  auto r = ReadJob(st);
  if (!r.ok()) return r.status();
  return std::optional<JobRecord>(std::move(*r));
}

absl::StatusOr<std::optional<JobRecord>> QueryOne(sqlite3* db, const std::string& sql,
                                                  const std::function<void(Statement&)>& bind) {
  Statement st(db, sql.c_str());
  if (auto s = st.prepared(); !s.ok()) return s;
  bind(st);
  return StepOne(st);
}

absl::StatusOr<std::vector<JobRecord>> QueryMany(sqlite3* db, const std::string& sql,
                                                 const std::function<void(Statement&)>& bind) {
  Statement st(db, sql.c_str());
  if (auto s = st.prepared(); !s.ok()) return s;
  bind(st);
  std::vector<JobRecord> out;
  int rc;
  while ((rc = st.Step()) == SQLITE_ROW) {
    auto r = ReadJob(st);
    if (!r.ok()) {
      if (SkipUnreadableJobRow(r.status())) continue;
      return r.status();
    }
    out.push_back(std::move(*r));
  }
  if (rc != SQLITE_DONE) return st.Error("query");
  return out;
}

// FAILED_PRECONDITION when a newer server has migrated the database past
// what this one knows.
absl::Status CheckSchemaVersion(sqlite3* db, const std::filesystem::path& file) {
  Statement st(db, "SELECT MAX(version) FROM schema_version");
  if (!st.prepared().ok()) return absl::OkStatus();  // no table yet: version 0 or 1
  if (st.Step() != SQLITE_ROW) return st.Error("read schema version");
  const int64_t version = st.Int(0);
  if (version > kSchemaVersion) {
    return absl::FailedPreconditionError(absl::StrCat(file.string(), ": schema version ", version,
                                                      " is newer than this server knows (", kSchemaVersion,
                                                      "); run the newer impostor-server or restore a backup"));
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status SqliteJobStore::MigrateVersions(const std::filesystem::path& file) {
  char* err = nullptr;
  auto exec = [&](const std::string& sql, const std::string& what) -> absl::Status {
    if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &err) == SQLITE_OK) return absl::OkStatus();
    std::string msg = err ? err : "unknown error";
    sqlite3_free(err);
    sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    return absl::InternalError(absl::StrCat("cannot migrate ", file.string(), " (", what, "): ", msg));
  };
  if (auto s = exec("CREATE TABLE IF NOT EXISTS schema_version (version INTEGER NOT NULL)", "schema_version");
      !s.ok()) {
    return s;
  }
  Statement st(db_, "SELECT COALESCE(MAX(version), 1) FROM schema_version");
  if (auto s = st.prepared(); !s.ok()) return s;
  if (st.Step() != SQLITE_ROW) return st.Error("read schema version");
  const int64_t version = st.Int(0);
  for (int v = static_cast<int>(version) + 1; v <= kSchemaVersion; ++v) {
    if (auto s = exec("BEGIN IMMEDIATE", "begin"); !s.ok()) return s;
    if (auto s = exec(kVersionedMigrations[v - 2], absl::StrCat("to version ", v)); !s.ok()) return s;
    if (auto s = exec(absl::StrCat("DELETE FROM schema_version; INSERT INTO schema_version VALUES (", v, ")"),
                      "record version");
        !s.ok()) {
      return s;
    }
    if (auto s = exec("COMMIT", "commit"); !s.ok()) return s;
  }
  return absl::OkStatus();
}

absl::StatusOr<std::unique_ptr<SqliteJobStore>> SqliteJobStore::Open(const std::filesystem::path& file) {
  // No schema yet: the version check must see the file as it was found.
  auto opened = OpenSqliteDatabase(file, "");
  if (!opened.ok()) return opened.status();
  sqlite3* db = *opened;
  if (auto s = CheckSchemaVersion(db, file); !s.ok()) {
    sqlite3_close(db);
    return s;
  }
  char* err = nullptr;
  if (sqlite3_exec(db, kSchema, nullptr, nullptr, &err) != SQLITE_OK) {
    std::string msg = err ? err : "unknown error";
    sqlite3_free(err);
    sqlite3_close(db);
    return absl::InternalError(absl::StrCat("cannot initialise ", file.string(), ": ", msg));
  }
  for (const Migration& m : kMigrations) {
    Statement has(db, "SELECT COUNT(*) FROM pragma_table_info('jobs') WHERE name = ?1");
    if (auto s = has.prepared(); !s.ok()) {
      sqlite3_close(db);
      return s;
    }
    has.Bind(1, std::string(m.column));
    if (has.Step() != SQLITE_ROW) {
      absl::Status s = has.Error("read schema");
      sqlite3_close(db);
      return s;
    }
    if (has.Int(0) > 0) continue;
    if (sqlite3_exec(db, m.sql, nullptr, nullptr, &err) != SQLITE_OK) {
      std::string msg = err ? err : "unknown error";
      sqlite3_free(err);
      sqlite3_close(db);
      return absl::InternalError(absl::StrCat("cannot migrate ", file.string(), " (column ", m.column, "): ", msg));
    }
  }
  if (sqlite3_exec(db, kLateIndexes, nullptr, nullptr, &err) != SQLITE_OK) {
    std::string msg = err ? err : "unknown error";
    sqlite3_free(err);
    sqlite3_close(db);
    return absl::InternalError(absl::StrCat("cannot index ", file.string(), ": ", msg));
  }
  auto store = std::unique_ptr<SqliteJobStore>(new SqliteJobStore(db));
  if (auto s = store->BackfillResultBlobs(); !s.ok()) return s;
  if (auto s = store->MigrateVersions(file); !s.ok()) return s;
  return store;
}

absl::Status SqliteJobStore::BackfillResultBlobs() {
  Statement any(db_, "SELECT (SELECT COUNT(*) FROM result_blobs), (SELECT COUNT(*) FROM results)");
  if (auto s = any.prepared(); !s.ok()) return s;
  if (any.Step() != SQLITE_ROW) return any.Error("count result blobs");
  if (any.Int(0) > 0 || any.Int(1) == 0) return absl::OkStatus();
  auto results = ResultsByLastUse();
  if (!results.ok()) return results.status();
  for (const StoredResult& r : *results) {
    if (auto s = IndexResultBlobs(r.manifest); !s.ok()) return s;
  }
  return absl::OkStatus();
}

SqliteJobStore::~SqliteJobStore() {
  find_by_request_id_.reset();  // finalised before the connection closes
  sqlite3_close(db_);
}

namespace {

void BindJob(Statement& st, const JobRecord& r) {
  v1::Job job = r.job;
  job.clear_result();  // results live in their own table, once per key
  v1::SubmitBakeRequest request;
  *request.mutable_mesh() = r.mesh;
  *request.mutable_parameters() = r.parameters;
  if (r.gate.has_min_iou() || r.gate.has_min_psnr_db()) *request.mutable_gate() = r.gate;
  for (const std::string& tag : r.required_tags) request.add_required_tags(tag);
  st.Bind(1, r.job.job_id());
  st.Bind(2, r.job.cache_key());
  st.Bind(3, static_cast<int64_t>(r.job.state()));
  st.Bind(4, r.job.created_ms());
  st.Bind(5, r.lease_id);
  st.Bind(6, r.lease_deadline_ms);
  st.Bind(7, r.worker_id);
  st.BindBlob(8, job.SerializeAsString());
  st.BindBlob(9, request.SerializeAsString());
  st.Bind(10, r.leader_job_id);
  st.Bind(11, int64_t{r.requester_cancelled ? 1 : 0});
  st.Bind(12, r.client_id);
  st.Bind(13, int64_t{r.lease_priority});
  st.Bind(14, r.request_id);
  st.Bind(15, int64_t{r.lease_expiries});
  st.Bind(16, r.owner);
  st.Bind(17, r.lease_holder);
}

}  // namespace

absl::Status SqliteJobStore::Insert(const JobRecord& record) {
  Statement st(db_, "INSERT INTO jobs (job_id, cache_key, state, created_ms, lease_id, lease_deadline_ms, "
                    "worker_id, job, request, leader_job_id, requester_cancelled, client_id, priority, request_id, "
                    "lease_expiries, owner, lease_holder) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, "
                    "?15, ?16, ?17)");
  if (auto s = st.prepared(); !s.ok()) return s;
  BindJob(st, record);
  if (st.Step() != SQLITE_DONE) {
    if (sqlite3_extended_errcode(db_) == SQLITE_CONSTRAINT_UNIQUE ||
        sqlite3_extended_errcode(db_) == SQLITE_CONSTRAINT_PRIMARYKEY) {
      return absl::AlreadyExistsError(absl::StrCat("job ", record.job.job_id(), ": ", sqlite3_errmsg(db_)));
    }
    return st.Error("insert job");
  }
  return absl::OkStatus();
}

absl::Status SqliteJobStore::Update(const JobRecord& record) {
  Statement st(db_, "UPDATE jobs SET cache_key = ?2, state = ?3, created_ms = ?4, lease_id = ?5, "
                    "lease_deadline_ms = ?6, worker_id = ?7, job = ?8, request = ?9, leader_job_id = ?10, "
                    "requester_cancelled = ?11, client_id = ?12, priority = ?13, request_id = ?14, "
                    "lease_expiries = ?15, owner = ?16, lease_holder = ?17, row_version = ?18 + 1 "
                    "WHERE job_id = ?1 AND row_version = ?18");
  if (auto s = st.prepared(); !s.ok()) return s;
  BindJob(st, record);
  st.Bind(18, record.row_version);
  if (st.Step() != SQLITE_DONE) return st.Error("update job");
  if (sqlite3_changes(db_) > 0) return absl::OkStatus();
  auto now = Get(record.job.job_id());
  if (!now.ok()) return now.status();
  if (!now->has_value()) return absl::NotFoundError(absl::StrCat("job ", record.job.job_id(), " not found"));
  return absl::AbortedError(absl::StrCat("job ", record.job.job_id(), " changed since it was read (version ",
                                         record.row_version, ", now ", (*now)->row_version, "); retry"));
}

absl::StatusOr<std::optional<JobRecord>> SqliteJobStore::Get(const std::string& job_id) {
  return QueryOne(db_, absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE job_id = ?1"),
                  [&](Statement& st) { st.Bind(1, job_id); });
}

absl::StatusOr<std::optional<JobRecord>> SqliteJobStore::OldestQueued() {
  return QueryOne(db_,
                  absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE state = ?1 AND leader_job_id = '' ORDER BY created_ms, rowid LIMIT 1"),
                  [&](Statement& st) { st.Bind(1, static_cast<int64_t>(v1::JOB_STATE_QUEUED)); });
}

absl::StatusOr<std::vector<JobRecord>> SqliteJobStore::QueueHeadsPerClient(
    const std::vector<std::string>& skip_job_ids) {
  // Queued leaders not skipped: "job_id NOT IN (?2, ?3, ...)", one parameter
  // per skipped id (the scheduler skips a few at most).
  std::string queued = "state = ?1 AND leader_job_id = ''";
  if (!skip_job_ids.empty()) {
    queued += " AND job_id NOT IN (";
    for (size_t i = 0; i < skip_job_ids.size(); ++i) absl::StrAppend(&queued, i == 0 ? "?" : ", ?", i + 2);
    queued += ")";
  }
  return QueryMany(db_,
                   absl::StrCat("SELECT ", kJobColumns, " FROM (SELECT ", kJobColumns,
                                ", ROW_NUMBER() OVER (PARTITION BY client_id ORDER BY created_ms, rowid) AS n "
                                "FROM jobs WHERE ", queued, " AND priority = (SELECT MAX(priority) FROM jobs WHERE ",
                                queued, ")) WHERE n = 1"),
                   [&](Statement& st) {
                     st.Bind(1, static_cast<int64_t>(v1::JOB_STATE_QUEUED));
                     for (size_t i = 0; i < skip_job_ids.size(); ++i) st.Bind(static_cast<int>(i + 2), skip_job_ids[i]);
                   });
}

absl::StatusOr<std::map<std::string, int64_t>> SqliteJobStore::RunningPerClient() {
  Statement st(db_, "SELECT client_id, COUNT(*) FROM jobs WHERE state = ?1 AND leader_job_id = '' GROUP BY client_id");
  if (auto s = st.prepared(); !s.ok()) return s;
  st.Bind(1, static_cast<int64_t>(v1::JOB_STATE_RUNNING));
  std::map<std::string, int64_t> out;
  int rc;
  while ((rc = st.Step()) == SQLITE_ROW) out[st.Text(0)] = st.Int(1);
  if (rc != SQLITE_DONE) return st.Error("count running");
  return out;
}

absl::StatusOr<std::vector<JobStore::RunningLease>> SqliteJobStore::RunningLeases() {
  Statement st(db_, "SELECT worker_id, client_id, owner FROM jobs WHERE state = ?1 AND leader_job_id = ''");
  if (auto s = st.prepared(); !s.ok()) return s;
  st.Bind(1, static_cast<int64_t>(v1::JOB_STATE_RUNNING));
  std::vector<RunningLease> out;
  int rc;
  while ((rc = st.Step()) == SQLITE_ROW) out.push_back({st.Text(0), st.Text(1), st.Text(2)});
  if (rc != SQLITE_DONE) return st.Error("running leases");
  return out;
}

absl::StatusOr<std::vector<JobRecord>> SqliteJobStore::QueuedOfTeam(const std::string& team, int limit) {
  return QueryMany(db_,
                   absl::StrCat("SELECT ", kJobColumns,
                                " FROM jobs WHERE state = ?1 AND leader_job_id = '' AND (owner = ?2 OR client_id = ?2) "
                                "ORDER BY priority DESC, created_ms, rowid LIMIT ?3"),
                   [&](Statement& st) {
                     st.Bind(1, static_cast<int64_t>(v1::JOB_STATE_QUEUED));
                     st.Bind(2, team);
                     st.Bind(3, static_cast<int64_t>(limit));
                   });
}

absl::StatusOr<std::optional<JobRecord>> SqliteJobStore::ActiveWithKey(const std::string& cache_key) {
  return QueryOne(db_,
                  absl::StrCat("SELECT ", kJobColumns,
                               " FROM jobs WHERE cache_key = ?1 AND state IN (?2, ?3) AND leader_job_id = '' "
                               "ORDER BY created_ms LIMIT 1"),
                  [&](Statement& st) {
                    st.Bind(1, cache_key);
                    st.Bind(2, static_cast<int64_t>(v1::JOB_STATE_QUEUED));
                    st.Bind(3, static_cast<int64_t>(v1::JOB_STATE_RUNNING));
                  });
}

absl::StatusOr<std::vector<JobRecord>> SqliteJobStore::ActiveFollowers(const std::string& leader_job_id) {
  return QueryMany(db_, absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE leader_job_id = ?1 AND state IN (?2, ?3)"),
                   [&](Statement& st) {
                     st.Bind(1, leader_job_id);
                     st.Bind(2, static_cast<int64_t>(v1::JOB_STATE_QUEUED));
                     st.Bind(3, static_cast<int64_t>(v1::JOB_STATE_RUNNING));
                   });
}

absl::StatusOr<int64_t> SqliteJobStore::CountPending(const std::string& client_id) {
  Statement st(db_, client_id.empty()
                        ? "SELECT COUNT(*) FROM jobs WHERE state IN (?1, ?2) AND requester_cancelled = 0"
                        : "SELECT COUNT(*) FROM jobs WHERE state IN (?1, ?2) AND requester_cancelled = 0 "
                          "AND client_id = ?3");
  if (auto s = st.prepared(); !s.ok()) return s;
  st.Bind(1, static_cast<int64_t>(v1::JOB_STATE_QUEUED));
  st.Bind(2, static_cast<int64_t>(v1::JOB_STATE_RUNNING));
  if (!client_id.empty()) st.Bind(3, client_id);
  if (st.Step() != SQLITE_ROW) return st.Error("count pending");
  return st.Int(0);
}

absl::StatusOr<std::optional<JobRecord>> SqliteJobStore::FindByRequestId(const std::string& client_id,
                                                                   const std::string& request_id) {
  if (find_by_request_id_ == nullptr) {
    auto prepared = std::make_unique<SqliteStatement>(
        db_, absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE client_id = ?1 AND request_id = ?2").c_str(),
        "sqlite");
    if (auto s = prepared->prepared(); !s.ok()) return s;
    find_by_request_id_ = std::move(prepared);
  }
  SqliteStatement& st = *find_by_request_id_;
  absl::Cleanup reset = [&st] { st.Reset(); };
  st.Bind(1, client_id);
  st.Bind(2, request_id);
  return StepOne(st);
}

absl::StatusOr<std::vector<JobRecord>> SqliteJobStore::RunningOnWorker(const std::string& worker_id) {
  return QueryMany(db_,
                   absl::StrCat("SELECT ", kJobColumns,
                                " FROM jobs WHERE worker_id = ?1 AND state = ?2 AND leader_job_id = ''"),
                   [&](Statement& st) {
                     st.Bind(1, worker_id);
                     st.Bind(2, static_cast<int64_t>(v1::JOB_STATE_RUNNING));
                   });
}

absl::StatusOr<std::vector<JobRecord>> SqliteJobStore::FinishedLeadersWithWaitingFollowers(int limit) {
  // States: 3..5 SUCCEEDED, FAILED, CANCELLED; 1, 2 QUEUED, RUNNING. Asked
  // from the waiting followers' side (the live queue, few) so that the
  // engine can look leaders up by job_id instead of walking finished jobs.
  return QueryMany(db_,
                   absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE leader_job_id = '' AND state IN (3, 4, 5) AND job_id IN "
                                "(SELECT leader_job_id FROM jobs WHERE state IN (1, 2) AND leader_job_id <> '') "
                                "LIMIT ?1"),
                   [&](Statement& st) { st.Bind(1, static_cast<int64_t>(limit)); });
}

absl::StatusOr<std::vector<JobRecord>> SqliteJobStore::ExpiredLeases(int64_t now_ms) {
  return QueryMany(db_, absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE state = ?1 AND lease_deadline_ms < ?2"),
                   [&](Statement& st) {
                     st.Bind(1, static_cast<int64_t>(v1::JOB_STATE_RUNNING));
                     st.Bind(2, now_ms);
                   });
}

absl::Status SqliteJobStore::PutResult(const v1::Manifest& manifest, int64_t now_ms) {
  Statement st(db_, "INSERT INTO results (cache_key, manifest, created_ms, last_used_ms) VALUES (?1, ?2, ?3, ?3) "
                    "ON CONFLICT (cache_key) DO UPDATE SET manifest = excluded.manifest, "
                    "last_used_ms = excluded.last_used_ms");
  if (auto s = st.prepared(); !s.ok()) return s;
  st.Bind(1, manifest.cache_key());
  st.BindBlob(2, manifest.SerializeAsString());
  st.Bind(3, now_ms);
  if (st.Step() != SQLITE_DONE) return st.Error("insert result");
  return IndexResultBlobs(manifest);
}

absl::Status SqliteJobStore::IndexResultBlobs(const v1::Manifest& manifest) {
  Statement clear(db_, "DELETE FROM result_blobs WHERE cache_key = ?1");
  if (auto s = clear.prepared(); !s.ok()) return s;
  clear.Bind(1, manifest.cache_key());
  if (clear.Step() != SQLITE_DONE) return clear.Error("index result blobs");
  std::vector<std::string> hashes = {manifest.manifest_json().hash()};
  for (const auto& map : manifest.maps()) hashes.push_back(map.digest().hash());
  for (const std::string& hash : hashes) {
    if (hash.empty()) continue;
    Statement st(db_, "INSERT OR IGNORE INTO result_blobs (hash, cache_key) VALUES (?1, ?2)");
    if (auto s = st.prepared(); !s.ok()) return s;
    st.Bind(1, hash);
    st.Bind(2, manifest.cache_key());
    if (st.Step() != SQLITE_DONE) return st.Error("index result blobs");
  }
  return absl::OkStatus();
}

absl::StatusOr<bool> SqliteJobStore::IsResultBlob(const std::string& hash) {
  Statement st(db_, "SELECT 1 FROM result_blobs WHERE hash = ?1 LIMIT 1");
  if (auto s = st.prepared(); !s.ok()) return s;
  st.Bind(1, hash);
  const int rc = st.Step();
  if (rc == SQLITE_ROW) return true;
  if (rc != SQLITE_DONE) return st.Error("query result blobs");
  return false;
}

absl::StatusOr<int64_t> SqliteJobStore::CountPendingOwnedBy(const std::string& owner) {
  Statement st(db_, "SELECT COUNT(*) FROM jobs WHERE state IN (?1, ?2) AND requester_cancelled = 0 AND owner = ?3");
  if (auto s = st.prepared(); !s.ok()) return s;
  st.Bind(1, static_cast<int64_t>(v1::JOB_STATE_QUEUED));
  st.Bind(2, static_cast<int64_t>(v1::JOB_STATE_RUNNING));
  st.Bind(3, owner);
  if (st.Step() != SQLITE_ROW) return st.Error("count pending of owner");
  return st.Int(0);
}

absl::StatusOr<std::vector<JobRecord>> SqliteJobStore::RunningLeasedBy(const std::string& lease_holder) {
  return QueryMany(db_,
                   absl::StrCat("SELECT ", kJobColumns,
                                " FROM jobs WHERE lease_holder = ?1 AND state = ?2 AND leader_job_id = ''"),
                   [&](Statement& st) {
                     st.Bind(1, lease_holder);
                     st.Bind(2, static_cast<int64_t>(v1::JOB_STATE_RUNNING));
                   });
}

absl::StatusOr<std::optional<v1::Manifest>> SqliteJobStore::GetResult(const std::string& cache_key) {
  Statement st(db_, "SELECT manifest FROM results WHERE cache_key = ?1");
  if (auto s = st.prepared(); !s.ok()) return s;
  st.Bind(1, cache_key);
  const int rc = st.Step();
  if (rc == SQLITE_DONE) return std::optional<v1::Manifest>();
  if (rc != SQLITE_ROW) return st.Error("query result");
  v1::Manifest m;
  if (!m.ParseFromString(st.Blob(0))) return absl::DataLossError("result " + cache_key + ": stored manifest does not parse");
  return std::optional<v1::Manifest>(std::move(m));
}

absl::Status SqliteJobStore::TouchResult(const std::string& cache_key, int64_t now_ms) {
  Statement st(db_, "UPDATE results SET last_used_ms = ?2 WHERE cache_key = ?1");
  if (auto s = st.prepared(); !s.ok()) return s;
  st.Bind(1, cache_key);
  st.Bind(2, now_ms);
  if (st.Step() != SQLITE_DONE) return st.Error("touch result");
  return absl::OkStatus();
}

absl::StatusOr<bool> SqliteJobStore::PinResult(const std::string& cache_key, bool pinned) {
  Statement st(db_, "UPDATE results SET pinned = ?2 WHERE cache_key = ?1");
  if (auto s = st.prepared(); !s.ok()) return s;
  st.Bind(1, cache_key);
  st.Bind(2, int64_t{pinned ? 1 : 0});
  if (st.Step() != SQLITE_DONE) return st.Error("pin result");
  return sqlite3_changes(db_) > 0;
}

absl::StatusOr<std::vector<JobStore::StoredResult>> SqliteJobStore::ResultsByLastUse() {
  Statement st(db_, "SELECT cache_key, manifest, pinned FROM results ORDER BY last_used_ms, created_ms");
  if (auto s = st.prepared(); !s.ok()) return s;
  std::vector<StoredResult> out;
  int rc;
  while ((rc = st.Step()) == SQLITE_ROW) {
    StoredResult r;
    if (!r.manifest.ParseFromString(st.Blob(1))) return absl::DataLossError("result " + st.Text(0) + " does not parse");
    r.pinned = st.Int(2) != 0;
    out.push_back(std::move(r));
  }
  if (rc != SQLITE_DONE) return st.Error("list results");
  return out;
}

absl::StatusOr<std::vector<JobRecord>> SqliteJobStore::Pending() {
  return QueryMany(db_, absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE state IN (?1, ?2)"),
                   [&](Statement& st) {
                     st.Bind(1, static_cast<int64_t>(v1::JOB_STATE_QUEUED));
                     st.Bind(2, static_cast<int64_t>(v1::JOB_STATE_RUNNING));
                   });
}

absl::Status SqliteJobStore::DeleteResult(const std::string& cache_key) {
  Statement st(db_, "DELETE FROM results WHERE cache_key = ?1");
  if (auto s = st.prepared(); !s.ok()) return s;
  st.Bind(1, cache_key);
  if (st.Step() != SQLITE_DONE) return st.Error("delete result");
  Statement blobs(db_, "DELETE FROM result_blobs WHERE cache_key = ?1");
  if (auto s = blobs.prepared(); !s.ok()) return s;
  blobs.Bind(1, cache_key);
  if (blobs.Step() != SQLITE_DONE) return blobs.Error("delete result blobs");
  return absl::OkStatus();
}

absl::StatusOr<std::map<int, int64_t>> SqliteJobStore::CountByState() {
  Statement st(db_, absl::StrCat("SELECT ", kShownStateSql, " AS shown, COUNT(*) FROM jobs GROUP BY shown").c_str());
  if (auto s = st.prepared(); !s.ok()) return s;
  std::map<int, int64_t> out;
  int rc;
  while ((rc = st.Step()) == SQLITE_ROW) out[static_cast<int>(st.Int(0))] = st.Int(1);
  if (rc != SQLITE_DONE) return st.Error("count by state");
  return out;
}

absl::StatusOr<std::vector<JobRecord>> SqliteJobStore::ListJobs(int state, int limit, const std::optional<JobCursor>& after) {
  std::string sql = absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE 1");
  if (state != 0) sql += absl::StrCat(" AND ", kShownStateSql, " = ?1");
  if (after) sql += " AND (created_ms < ?2 OR (created_ms = ?2 AND job_id < ?3))";
  sql += " ORDER BY created_ms DESC, job_id DESC LIMIT ?4";
  return QueryMany(db_, sql, [&](Statement& st) {
    if (state != 0) st.Bind(1, int64_t{state});
    if (after) {
      st.Bind(2, after->created_ms);
      st.Bind(3, after->job_id);
    }
    st.Bind(4, int64_t{limit});
  });
}

namespace {

constexpr const char* kResultColumns = "cache_key, manifest, pinned, created_ms, last_used_ms";

absl::StatusOr<JobStore::StoredResult> ReadResult(const Statement& st) {
  JobStore::StoredResult r;
  if (!r.manifest.ParseFromString(st.Blob(1))) return absl::DataLossError("result " + st.Text(0) + " does not parse");
  r.pinned = st.Int(2) != 0;
  r.created_ms = st.Int(3);
  r.last_used_ms = st.Int(4);
  return r;
}

}  // namespace

absl::StatusOr<std::vector<JobStore::StoredResult>> SqliteJobStore::ListResults(int limit,
                                                                         const std::optional<ResultCursor>& after) {
  std::string sql = absl::StrCat("SELECT ", kResultColumns, " FROM results");
  if (after) sql += " WHERE created_ms < ?1 OR (created_ms = ?1 AND cache_key < ?2)";
  sql += " ORDER BY created_ms DESC, cache_key DESC LIMIT ?3";
  Statement st(db_, sql.c_str());
  if (auto s = st.prepared(); !s.ok()) return s;
  if (after) {
    st.Bind(1, after->created_ms);
    st.Bind(2, after->cache_key);
  }
  st.Bind(3, int64_t{limit});
  std::vector<StoredResult> out;
  int rc;
  while ((rc = st.Step()) == SQLITE_ROW) {
    auto r = ReadResult(st);
    if (!r.ok()) return r.status();
    out.push_back(std::move(*r));
  }
  if (rc != SQLITE_DONE) return st.Error("list results");
  return out;
}

absl::StatusOr<std::string> SqliteJobStore::OldestJobWithKey(const std::string& cache_key) {
  Statement st(db_, "SELECT job_id FROM jobs WHERE cache_key = ?1 ORDER BY created_ms LIMIT 1");
  if (auto s = st.prepared(); !s.ok()) return s;
  st.Bind(1, cache_key);
  const int rc = st.Step();
  if (rc == SQLITE_DONE) return std::string();
  if (rc != SQLITE_ROW) return st.Error("query job by key");
  return st.Text(0);
}

absl::StatusOr<std::optional<JobStore::StoredResult>> SqliteJobStore::GetStoredResult(const std::string& cache_key) {
  Statement st(db_, absl::StrCat("SELECT ", kResultColumns, " FROM results WHERE cache_key = ?1").c_str());
  if (auto s = st.prepared(); !s.ok()) return s;
  st.Bind(1, cache_key);
  const int rc = st.Step();
  if (rc == SQLITE_DONE) return std::optional<StoredResult>();
  if (rc != SQLITE_ROW) return st.Error("query result");
  auto r = ReadResult(st);
  if (!r.ok()) return r.status();
  return std::optional<StoredResult>(std::move(*r));
}

}  // namespace impostor

namespace impostor {

absl::StatusOr<std::optional<JobRecord>> SqliteJobStore::ClaimQueued(const std::vector<std::string>& job_ids,
                                                                     const LeaseGrant& grant) {
  // One process owns the file, so a transaction is enough to make the
  // check-and-set atomic.
  if (sqlite3_exec(db_, "BEGIN IMMEDIATE", nullptr, nullptr, nullptr) != SQLITE_OK) {
    return SqliteError(db_, "sqlite", "claim");
  }
  // In WAL mode the claim's pages reach the disk at COMMIT: a full disk
  // fails the COMMIT (SQLite then rolls the transaction back), and the job
  // is no lease to hand out.
  auto commit = [&]() -> absl::Status {
    if (sqlite3_exec(db_, "COMMIT", nullptr, nullptr, nullptr) == SQLITE_OK) return absl::OkStatus();
    absl::Status failed = SqliteError(db_, "sqlite", "claim commit");
    if (!sqlite3_get_autocommit(db_)) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    return failed;
  };
  for (const std::string& id : job_ids) {
    auto r = Get(id);
    if (!r.ok()) {
      sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
      return r.status();
    }
    if (!r->has_value() || (*r)->job.state() != v1::JOB_STATE_QUEUED || !(*r)->leader_job_id.empty()) continue;
    JobRecord& claimed = **r;
    ApplyLeaseGrant(claimed, grant);
    if (auto s = Update(claimed); !s.ok()) {
      sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
      return s;
    }
    if (auto s = commit(); !s.ok()) return s;
    ++claimed.row_version;
    return std::move(*r);
  }
  if (auto s = commit(); !s.ok()) return s;
  return std::optional<JobRecord>();
}

absl::Status SqliteJobStore::NoteServed(const std::string& client_id) {
  Statement st(db_, "INSERT INTO client_served (client_id, served_seq) VALUES "
                    "(?1, (SELECT COALESCE(MAX(served_seq), 0) + 1 FROM client_served)) "
                    "ON CONFLICT (client_id) DO UPDATE SET served_seq = excluded.served_seq");
  if (auto s = st.prepared(); !s.ok()) return s;
  st.Bind(1, client_id);
  if (st.Step() != SQLITE_DONE) return st.Error("note served");
  return absl::OkStatus();
}

absl::StatusOr<std::map<std::string, int64_t>> SqliteJobStore::LastServed() {
  Statement st(db_, "SELECT client_id, served_seq FROM client_served");
  if (auto s = st.prepared(); !s.ok()) return s;
  std::map<std::string, int64_t> out;
  int rc;
  while ((rc = st.Step()) == SQLITE_ROW) out[st.Text(0)] = st.Int(1);
  if (rc != SQLITE_DONE) return st.Error("read served");
  return out;
}

// --- Serving speed (issue 18) ---

absl::Status SqliteJobStore::TouchResults(const std::map<std::string, int64_t>& last_used_ms) {
  if (last_used_ms.empty()) return absl::OkStatus();
  if (sqlite3_exec(db_, "BEGIN IMMEDIATE", nullptr, nullptr, nullptr) != SQLITE_OK) {
    return SqliteError(db_, "sqlite", "begin");
  }
  absl::Status status;
  for (auto it = last_used_ms.begin(); status.ok() && it != last_used_ms.end(); ++it) {
    Statement st(db_, "UPDATE results SET last_used_ms = MAX(last_used_ms, ?2) WHERE cache_key = ?1");
    status = st.prepared();
    if (!status.ok()) break;
    st.Bind(1, it->first);
    st.Bind(2, it->second);
    if (st.Step() != SQLITE_DONE) status = st.Error("touch results");
  }
  if (status.ok() && sqlite3_exec(db_, "COMMIT", nullptr, nullptr, nullptr) == SQLITE_OK) return status;
  if (status.ok()) status = SqliteError(db_, "sqlite", "commit");
  if (!sqlite3_get_autocommit(db_)) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
  return status;
}

absl::StatusOr<int64_t> SqliteJobStore::DeleteFinishedJobsCreatedBefore(int64_t cutoff_ms, int limit) {
  Statement st(db_,
               "DELETE FROM jobs WHERE job_id IN (SELECT job_id FROM jobs WHERE state IN (?1, ?2, ?3) "
               "AND created_ms < ?4 LIMIT ?5)");
  if (auto s = st.prepared(); !s.ok()) return s;
  st.Bind(1, int64_t{v1::JOB_STATE_SUCCEEDED});
  st.Bind(2, int64_t{v1::JOB_STATE_FAILED});
  st.Bind(3, int64_t{v1::JOB_STATE_CANCELLED});
  st.Bind(4, cutoff_ms);
  st.Bind(5, int64_t{limit});
  if (st.Step() != SQLITE_DONE) return st.Error("delete finished jobs");
  return int64_t{sqlite3_changes(db_)};
}

}  // namespace impostor
