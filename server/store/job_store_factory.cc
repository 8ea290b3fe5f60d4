#include "server/store/job_store_factory.h"

#include <filesystem>

#include "absl/strings/str_cat.h"
#include "server/store/postgres/postgres_job_store.h"
#include "server/store/sqlite/sqlite_job_store.h"

namespace impostor {

bool IsPostgresUrl(std::string_view url) {
  return url.substr(0, 13) == "postgresql://" || url.substr(0, 11) == "postgres://";
}

absl::Status ValidateDatabaseUrl(std::string_view url) {
  if (url.empty() || IsPostgresUrl(url)) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat("--database: expected a postgresql:// or postgres:// URL, got \"",
                                                 std::string(url.substr(0, url.find(':'))),
                                                 ":...\" (leave --database out for SQLite under --data)"));
}

absl::StatusOr<std::unique_ptr<JobStore>> OpenJobStore(const JobStoreConfig& config) {
  if (config.database_url.empty()) {
    if (config.data_dir.empty()) return absl::InvalidArgumentError("--data: required for the SQLite job store");
    return JobStore::Open(std::filesystem::path(config.data_dir) / "jobs.sqlite3");
  }
  if (auto s = ValidateDatabaseUrl(config.database_url); !s.ok()) return s;
  auto store = PostgresJobStore::Open({.url = config.database_url,
                                       .pool_size = config.pool_size,
                                       .statement_timeout_ms = config.statement_timeout_ms,
                                       .dead_link_seconds = config.dead_link_seconds,
                                       .maintenance_takeover_ms = config.maintenance_takeover_ms});
  if (!store.ok()) return store.status();
  return std::unique_ptr<JobStore>(std::move(*store));
}

}  // namespace impostor
