#include "server/store/token_store_factory.h"

#include <filesystem>
#include <fstream>

#include "server/store/job_store_factory.h"
#include "server/store/postgres/pg_url.h"
#include "server/store/postgres/postgres_token_store.h"

namespace impostor {

absl::StatusOr<TokenStorage> OpenTokenStorage(const TokenStoreConfig& config) {
  if (config.database_url.empty()) {
    if (config.data_dir.empty()) return absl::InvalidArgumentError("--data: required for the SQLite token store");
    auto tokens = OpenSqliteTokenStore(config.data_dir);
    if (!tokens.ok()) return tokens.status();
    auto quotas = OpenSqliteQuotaLedger(config.data_dir);
    if (!quotas.ok()) return quotas.status();
    return TokenStorage{.tokens = std::move(*tokens), .quotas = std::move(*quotas)};
  }
  if (auto s = ValidateDatabaseUrl(config.database_url); !s.ok()) return s;
  auto pg = OpenPostgresTokenStorage({.url = config.database_url,
                                      .statement_timeout_ms = config.statement_timeout_ms,
                                      .dead_link_seconds = config.dead_link_seconds});
  if (!pg.ok()) return pg.status();
  return TokenStorage{.tokens = std::move(pg->tokens), .quotas = std::move(pg->quotas)};
}

void NoteWhereTokensLive(const std::string& data_dir, const std::string& database_url) {
  const std::filesystem::path marker = std::filesystem::path(data_dir) / kTokensInDatabaseMarker;
  std::error_code ec;
  if (database_url.empty()) {
    std::filesystem::remove(marker, ec);
    return;
  }
  std::ofstream(marker) << RedactDatabaseUrl(database_url) << "\n";
}

std::string TokensInDatabaseOf(const std::string& data_dir) {
  std::ifstream in(std::filesystem::path(data_dir) / kTokensInDatabaseMarker);
  std::string url;
  if (!in || !std::getline(in, url)) return "";
  return url.empty() ? "PostgreSQL" : url;
}

}  // namespace impostor
