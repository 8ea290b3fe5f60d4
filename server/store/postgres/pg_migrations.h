// Versioned schema migrations on PostgreSQL, shared by every component that
// keeps tables in the farm's database (the job store, the token store and
// quota ledger): each component has its own list of migration scripts and
// its own one-row version table, so their schemas evolve independently.
//
// Apply runs inside one transaction under a transaction-scoped advisory
// lock, so replicas starting together migrate once (the others wait, then
// find the work done), and a failed script leaves the database as it was.
#ifndef IMPOSTOR_SERVER_STORE_POSTGRES_PG_MIGRATIONS_H_
#define IMPOSTOR_SERVER_STORE_POSTGRES_PG_MIGRATIONS_H_

#include <span>
#include <string>

#include "absl/status/status.h"
#include "server/store/postgres/pg_connection_pool.h"

namespace impostor {

struct PgMigrations {
  // For logs and errors: "job store", "token store".
  std::string component;
  // The component's version table (one INTEGER column `version`).
  std::string version_table;
  // Scripts; version = index + 1. Never edit a released one: append.
  std::span<const char* const> scripts;
};

// Brings the database to scripts.size(). FAILED_PRECONDITION naming the
// redacted URL when its version is newer than the binary knows; the
// failing script's error (naming its version) otherwise.
absl::Status ApplyPgMigrations(PgConnectionPool& pool, const PgMigrations& migrations);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_STORE_POSTGRES_PG_MIGRATIONS_H_
