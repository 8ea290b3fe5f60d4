// Tokens and quota windows on PostgreSQL (issue 15): the same TokenStore
// and QuotaLedger as the SQLite engine, kept in the --database the server
// replicas share, so a token created or revoked through any replica (or
// `impostor-server token ... --database URL`) is the same token on all of
// them, and a token's quota events are counted once across replicas.
//
// Tables `tokens` and `quota_events`, versioned by `token_schema_version`
// (pg_migrations.h), beside the job store's tables and independent of them.
// How fast a revocation reaches a running replica is the Authenticator's
// cache TTL (authenticator.h), not this store: every call here reads the
// database.
//
// Thread-safety: thread-safe (each call borrows a pooled connection).
#ifndef IMPOSTOR_SERVER_STORE_POSTGRES_POSTGRES_TOKEN_STORE_H_
#define IMPOSTOR_SERVER_STORE_POSTGRES_POSTGRES_TOKEN_STORE_H_

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "server/store/postgres/pg_dead_link.h"
#include "server/store/token_quotas.h"
#include "server/store/token_store.h"

namespace impostor {

// The token tables' schema version this binary writes.
int PostgresTokenSchemaVersion();

struct PostgresTokenStorage {
  std::unique_ptr<TokenStore> tokens;
  std::unique_ptr<QuotaLedger> quotas;  // shares the tokens' connection pool
};

struct PostgresTokenOptions {
  std::string url;
  int pool_size = 2;
  int statement_timeout_ms = 10'000;
  int dead_link_seconds = kDefaultDeadLinkSeconds;  // PgConnectionPool::Options
};

// Connects and migrates. UNAVAILABLE naming the redacted URL when the
// database cannot be reached; FAILED_PRECONDITION when its token schema is
// newer than this binary.
absl::StatusOr<PostgresTokenStorage> OpenPostgresTokenStorage(const PostgresTokenOptions& options);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_STORE_POSTGRES_POSTGRES_TOKEN_STORE_H_
