// Picks the engine of the token store and the quota ledger from the
// server's flags, as job_store_factory.h does for jobs: --database with a
// postgresql:// URL keeps tokens and quota windows in that database (shared
// by every replica on it); without it, DIR/tokens.sqlite3 under --data.
// The authenticator, the access guard and `impostor-server token` use the
// interfaces only, never an engine.
#ifndef IMPOSTOR_SERVER_STORE_TOKEN_STORE_FACTORY_H_
#define IMPOSTOR_SERVER_STORE_TOKEN_STORE_FACTORY_H_

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "server/store/postgres/pg_dead_link.h"
#include "server/store/token_quotas.h"
#include "server/store/token_store.h"

namespace impostor {

struct TokenStoreConfig {
  // --database: '' = SQLite under data_dir; else a postgresql:// URL.
  std::string database_url;
  // --data: where tokens.sqlite3 lives (SQLite only).
  std::string data_dir;
  // PostgreSQL only: the per-statement limit. Token checks are cached
  // (authenticator.h), so the pool is small.
  int statement_timeout_ms = 10'000;
  // PostgreSQL only: --database-dead-link-seconds (pg_dead_link.h).
  int dead_link_seconds = kDefaultDeadLinkSeconds;
};

struct TokenStorage {
  std::unique_ptr<TokenStore> tokens;
  std::unique_ptr<QuotaLedger> quotas;
};

// Both, opened and migrated. INVALID_ARGUMENT naming --database for a URL of
// another scheme, or --data when SQLite has no directory; the engine's error
// otherwise (a PostgreSQL URL named without its password).
absl::StatusOr<TokenStorage> OpenTokenStorage(const TokenStoreConfig& config);

// A server started with --database leaves this file in its --data (the
// redacted URL inside) and removes it when started without: so that
// `impostor-server token create --data DIR` on a replica's directory is
// refused, naming --database, instead of writing a tokens.sqlite3 that no
// replica reads.
inline constexpr char kTokensInDatabaseMarker[] = "tokens-in-database";
void NoteWhereTokensLive(const std::string& data_dir, const std::string& database_url);
// The redacted URL the marker names; '' when there is none.
std::string TokensInDatabaseOf(const std::string& data_dir);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_STORE_TOKEN_STORE_FACTORY_H_
