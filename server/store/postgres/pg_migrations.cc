#include "server/store/postgres/pg_migrations.h"

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

// pg_advisory_xact_lock's key for every component's migrations: one
// migration at a time in a database is plenty. ASCII "impostor".
constexpr int64_t kMigrationLockKey = 0x696d706f73746f72;

}  // namespace

absl::Status ApplyPgMigrations(PgConnectionPool& pool, const PgMigrations& m) {
  const int64_t known = static_cast<int64_t>(m.scripts.size());
  return pool.Transaction([&](PgSession& db) -> absl::Status {
    if (auto r = db.Exec("lock for migration", absl::StrCat("SELECT pg_advisory_xact_lock(", kMigrationLockKey, ")"));
        !r.ok()) {
      return r.status();
    }
    if (auto r = db.Exec(absl::StrCat("create ", m.version_table),
                         absl::StrCat("CREATE TABLE IF NOT EXISTS ", m.version_table, " (version INTEGER NOT NULL)"));
        !r.ok()) {
      return r.status();
    }
    auto v = db.Exec(absl::StrCat("read ", m.component, " schema version"),
                     absl::StrCat("SELECT COALESCE(MAX(version), 0) FROM ", m.version_table));
    if (!v.ok()) return v.status();
    const int64_t version = v->Int(0, 0);
    if (version > known) {
      return absl::FailedPreconditionError(absl::StrCat(
          "--database ", pool.redacted_url(), ": ", m.component, " schema version ", version,
          " is newer than this server knows (", known, "); run the newer impostor-server or restore a backup"));
    }
    for (int64_t next = version + 1; next <= known; ++next) {
      if (auto r = db.Exec(absl::StrCat("migrate ", m.component, " to schema version ", next), m.scripts[next - 1]);
          !r.ok()) {
        return r.status();
      }
      spdlog::info("event=schema_migrated engine=postgresql component=\"{}\" version={}", m.component, next);
    }
    if (version < known) {
      auto r = db.Exec("record schema version", absl::StrCat("DELETE FROM ", m.version_table));
      if (!r.ok()) return r.status();
      r = db.Exec("record schema version", absl::StrCat("INSERT INTO ", m.version_table, " VALUES ($1)"),
                  PgParams().Int(known));
      if (!r.ok()) return r.status();
    }
    return absl::OkStatus();
  });
}

}  // namespace impostor
