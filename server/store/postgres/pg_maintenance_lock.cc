#include "server/store/postgres/pg_maintenance_lock.h"

#include <libpq-fe.h>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

// How long a takeover waits for the stale holder's backend to exit.
constexpr int kTerminateWaitMs = 5000;

}  // namespace

PgMaintenanceLock::PgMaintenanceLock(PgConnectionPool* pool, PgClockOffset* clock, int64_t key, int64_t takeover_ms)
    : pool_(pool), clock_(clock), key_(key), takeover_ms_(takeover_ms) {}

PgMaintenanceLock::~PgMaintenanceLock() {
  std::lock_guard lock(mu_);
  if (conn_ != nullptr) PQfinish(conn_);
}

std::optional<PgMaintenanceLock::Rows> PgMaintenanceLock::Query(const std::string& sql) {
  PGresult* r = PQexec(conn_, sql.c_str());
  std::optional<Rows> out;
  if (r && PQresultStatus(r) == PGRES_TUPLES_OK) {
    out.emplace();
    for (int i = 0; i < PQntuples(r); ++i) {
      auto& row = out->emplace_back();
      for (int j = 0; j < PQnfields(r); ++j) row.emplace_back(PQgetvalue(r, i, j));
    }
  }
  PQclear(r);
  return out;
}

bool PgMaintenanceLock::Renew() {
  const int64_t sent = clock_->LocalNowMs();
  auto rows = Query(absl::StrCat(
      "INSERT INTO maintenance_holder (id, backend_pid, renewed_at) VALUES (1, pg_backend_pid(), clock_timestamp()) "
      "ON CONFLICT (id) DO UPDATE SET backend_pid = excluded.backend_pid, renewed_at = excluded.renewed_at "
      "RETURNING ",
      kDatabaseClockMsSql));
  if (!rows.has_value() || rows->size() != 1) return false;
  clock_->Note(sent, std::stoll((*rows)[0][0]), clock_->LocalNowMs());
  return true;
}

bool PgMaintenanceLock::EndStaleHolder() {
  // pg_locks splits a bigint advisory key into classid (high 32 bits) and
  // objid (low 32 bits), objsubid 1. Joining on it ends only a session that
  // holds the lock now, never a pid the row names from an older holder.
  const uint64_t key = static_cast<uint64_t>(key_);
  auto rows = Query(absl::StrCat(
      "SELECT h.backend_pid, (extract(epoch FROM clock_timestamp() - h.renewed_at) * 1000)::bigint, "
      "pg_terminate_backend(h.backend_pid, ", kTerminateWaitMs, ") "
      "FROM maintenance_holder h JOIN pg_locks l ON l.pid = h.backend_pid "
      "WHERE h.id = 1 AND l.locktype = 'advisory' AND l.granted AND l.objsubid = 1 AND l.classid = '",
      key >> 32, "'::oid AND l.objid = '", key & 0xffffffffu, "'::oid ",
      "AND h.renewed_at < clock_timestamp() - make_interval(secs => ", takeover_ms_ / 1000.0, ")"));
  if (!rows.has_value() || rows->empty()) return false;
  const auto& row = (*rows)[0];
  spdlog::warn("event=maintenance_lock_taken_over url={} stale_backend_pid={} stale_ms={} terminated={}",
               pool_->redacted_url(), row[0], row[1], row[2]);
  return row[2] == "t";
}

absl::Status PgMaintenanceLock::Lost(const std::string& what) {
  const std::string why = conn_ ? std::string(PQerrorMessage(conn_)) : "";
  if (conn_ != nullptr) PQfinish(conn_);
  conn_ = nullptr;
  held_ = false;
  absl::Status status = absl::UnavailableError(absl::StrCat(
      "postgresql maintenance lock (", pool_->redacted_url(), "): ", what, why.empty() ? "" : ": ",
      why.substr(0, why.find('\n'))));
  pool_->NoteUnreachable(status);
  return status;
}

absl::StatusOr<bool> PgMaintenanceLock::Hold() {
  std::lock_guard lock(mu_);
  if (conn_ != nullptr && held_) {
    // Still ours while the session lives; the renewal proves it does and
    // tells the others this replica still sweeps.
    if (Renew()) {
      pool_->NoteReachable();
      return true;
    }
    // The session ended: a database restart, a cut link, or another
    // replica found this one stale (it hung) and ended it.
    spdlog::warn("event=maintenance_lock_lost url={}", pool_->redacted_url());
    (void)Lost("session ended");
  }
  if (conn_ == nullptr || PQstatus(conn_) != CONNECTION_OK) {
    if (conn_ != nullptr) PQfinish(conn_);
    conn_ = nullptr;
    auto conn = pool_->Connect();
    if (!conn.ok()) {
      pool_->NoteUnreachable(conn.status());
      return conn.status();
    }
    conn_ = *conn;
  }
  // The database's clock comes along, so a replica that never holds the
  // role still writes its lease deadlines on the shared clock.
  const std::string try_lock = absl::StrCat("SELECT pg_try_advisory_lock(", key_, "), ", kDatabaseClockMsSql);
  auto try_once = [&]() -> bool {
    const int64_t sent = clock_->LocalNowMs();
    auto got = Query(try_lock);
    if (!got.has_value() || got->size() != 1) return false;
    clock_->Note(sent, std::stoll((*got)[0][1]), clock_->LocalNowMs());
    held_ = (*got)[0][0] == "t";
    return true;
  };
  if (!try_once()) return Lost("failed");
  if (!held_ && EndStaleHolder() && !try_once()) return Lost("failed");
  if (held_) {
    if (!Renew()) return Lost("first heartbeat failed");
    spdlog::info("event=maintenance_lock_acquired url={}", pool_->redacted_url());
  }
  pool_->NoteReachable();
  return held_;
}

}  // namespace impostor
