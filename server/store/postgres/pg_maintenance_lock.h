// Which replica on a PostgreSQL database runs farm-wide maintenance (lease
// expiry, store-cap eviction, retention): the one whose session holds a
// session advisory lock, so a replica that dies or whose session the
// database ends hands the role on by itself.
//
// A replica that hangs (SIGSTOP, a stuck disk, a deadlock) keeps its session
// open and so the lock, and without more the farm would stop expiring
// leases for as long as it hangs. So the holder also renews a heartbeat row
// (`maintenance_holder`: its backend pid and when it last renewed, on the
// database's clock) every time it asks, which is every sweep; another
// replica that finds the lock taken and that row older than `takeover_ms`
// ends the holder's session (pg_terminate_backend, allowed between sessions
// of the same role) and takes the lock.
//
// Why the lock plus a heartbeat rather than only a leadership row with an
// expiry: the lock still ends with the holder's session, at once, when a
// replica dies or its link is cut (no waiting out an expiry); the holder
// stays visible in pg_locks for operators; and terminating a stale holder's
// session makes it lose the role in the database, not only by a rule it
// would have to check after it wakes. Staleness is judged by the database's
// clock alone, so replicas' clocks do not matter.
//
// Thread-safety: thread-safe (one mutex around the lock's own connection).
#ifndef IMPOSTOR_SERVER_STORE_POSTGRES_PG_MAINTENANCE_LOCK_H_
#define IMPOSTOR_SERVER_STORE_POSTGRES_PG_MAINTENANCE_LOCK_H_

#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/store/postgres/pg_clock_offset.h"
#include "server/store/postgres/pg_connection_pool.h"

namespace impostor {

// SQL creating the heartbeat table (a migration of the job store's).
inline constexpr const char* kMaintenanceHolderTableSql = R"sql(
CREATE TABLE maintenance_holder (
  id          INTEGER PRIMARY KEY CHECK (id = 1),
  backend_pid INTEGER NOT NULL,     -- the holding session's pg_backend_pid()
  renewed_at  TIMESTAMPTZ NOT NULL  -- the database's clock at its last sweep
);
)sql";

class PgMaintenanceLock {
 public:
  // `pool` and `clock` must outlive the lock. `key` is the advisory lock's;
  // `takeover_ms` how long a holder may go without renewing before another
  // replica ends its session (more than a sweep can take: a statement
  // timeout or a reconnect window).
  PgMaintenanceLock(PgConnectionPool* pool, PgClockOffset* clock, int64_t key, int64_t takeover_ms);
  ~PgMaintenanceLock();

  // True while this replica holds the role (and renews its heartbeat);
  // false when another does. UNAVAILABLE naming the redacted URL when the
  // database cannot be asked (noted as an outage in the pool).
  absl::StatusOr<bool> Hold();

 private:
  using Rows = std::vector<std::vector<std::string>>;
  // The rows of `sql` on the lock's connection; none when the session failed.
  std::optional<Rows> Query(const std::string& sql);
  // Writes this session's heartbeat; false when the session failed.
  bool Renew();
  // Ends the holder's session when its heartbeat is older than takeover_ms;
  // true when it did.
  bool EndStaleHolder();
  absl::Status Lost(const std::string& what);

  PgConnectionPool* const pool_;
  PgClockOffset* const clock_;
  const int64_t key_;
  const int64_t takeover_ms_;
  std::mutex mu_;
  pg_conn* conn_ = nullptr;  // guarded by mu_; holds the lock while held_
  bool held_ = false;        // guarded by mu_
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_STORE_POSTGRES_PG_MAINTENANCE_LOCK_H_
