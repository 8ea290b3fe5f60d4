// Picks the job store engine from the server's flags: --database with a
// postgresql:// (or postgres://) URL opens PostgreSQL; without it, SQLite in
// the data directory (DIR/jobs.sqlite3), as before there were two engines.
#ifndef IMPOSTOR_SERVER_STORE_JOB_STORE_FACTORY_H_
#define IMPOSTOR_SERVER_STORE_JOB_STORE_FACTORY_H_

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "server/store/job_store.h"
#include "server/store/postgres/pg_dead_link.h"

namespace impostor {

struct JobStoreConfig {
  // --database: '' = SQLite under data_dir; else a postgresql:// URL.
  std::string database_url;
  // --data: where the SQLite file lives.
  std::string data_dir;
  // PostgreSQL only: connections in the pool and the per-statement limit.
  int pool_size = 8;
  int statement_timeout_ms = 10'000;
  // PostgreSQL only: --database-dead-link-seconds (pg_dead_link.h).
  int dead_link_seconds = kDefaultDeadLinkSeconds;
  // PostgreSQL only: --database-maintenance-takeover-seconds, in ms
  // (PostgresJobStore::Options::maintenance_takeover_ms).
  int64_t maintenance_takeover_ms = 30'000;
};

// True for the URL schemes the PostgreSQL engine takes.
bool IsPostgresUrl(std::string_view url);
// OK for '' (SQLite) and for IsPostgresUrl; INVALID_ARGUMENT naming
// --database and the scheme (never the rest of the URL) otherwise.
absl::Status ValidateDatabaseUrl(std::string_view url);

// The engine `config` names, opened and migrated. INVALID_ARGUMENT naming
// --database for a URL of another scheme; the engine's error otherwise
// (a PostgreSQL URL is named without its password).
absl::StatusOr<std::unique_ptr<JobStore>> OpenJobStore(const JobStoreConfig& config);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_STORE_JOB_STORE_FACTORY_H_
