// A small pool of libpq connections to one PostgreSQL database, with the
// reconnect an SRE expects: a statement that finds its connection broken
// (the database restarted, a network blip) reconnects and runs again, with
// backoff, for up to `reconnect_window_ms`, so a database restart costs a
// reconnect rather than a failed RPC or a lost job. Every connection gets
// the statement timeout, and notices a link that died without a reset
// within about `dead_link_seconds` on both ends (pg_dead_link.h). Errors
// name the URL without its password.
//
// Thread-safety: thread-safe; each Run borrows one connection.
#ifndef IMPOSTOR_SERVER_STORE_POSTGRES_PG_CONNECTION_POOL_H_
#define IMPOSTOR_SERVER_STORE_POSTGRES_PG_CONNECTION_POOL_H_

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/store/postgres/pg_dead_link.h"

struct pg_conn;
struct pg_result;

namespace impostor {

// Statement parameters: text values, or bytes sent in binary format
// (bytea). Numbered $1, $2, ... in the order added.
class PgParams {
 public:
  PgParams& Text(std::string v) { return Add(std::move(v), 0); }
  PgParams& Bytes(std::string v) { return Add(std::move(v), 1); }
  PgParams& Int(int64_t v) { return Add(std::to_string(v), 0); }
  // A text[] literal of `items` (for "= ANY($n::text[])").
  PgParams& TextArray(const std::vector<std::string>& items);
  size_t size() const { return values_.size(); }
  const std::vector<std::string>& values() const { return values_; }
  const std::vector<int>& formats() const { return formats_; }

 private:
  PgParams& Add(std::string v, int format) {
    values_.push_back(std::move(v));
    formats_.push_back(format);
    return *this;
  }
  std::vector<std::string> values_;
  std::vector<int> formats_;
};

// The rows of one statement (text format).
class PgRows {
 public:
  explicit PgRows(pg_result* r) : r_(r, &Clear) {}
  int size() const;
  int changed() const;  // rows an INSERT/UPDATE/DELETE touched
  std::string Text(int row, int col) const;
  int64_t Int(int row, int col) const;
  std::string Bytes(int row, int col) const;  // a bytea column, decoded
  bool IsNull(int row, int col) const;

 private:
  static void Clear(pg_result* r);
  std::shared_ptr<pg_result> r_;
};

// The rows of a statement's answer, each read by `read(rows, i)` (an
// absl::StatusOr<T>), in order: the statement's error, or the first row
// that does not read (its error), or every row.
template <typename T, typename Read>
absl::StatusOr<std::vector<T>> ReadEachRow(const absl::StatusOr<PgRows>& rows, Read read) {
  if (!rows.ok()) return rows.status();
  std::vector<T> out;
  out.reserve(static_cast<size_t>(rows->size()));
  for (int i = 0; i < rows->size(); ++i) {
    absl::StatusOr<T> r = read(*rows, i);
    if (!r.ok()) return r.status();
    out.push_back(std::move(*r));
  }
  return out;
}

// A failed statement's status from its SQLSTATE (`sqlstate`, "" when none
// came) and `text` (what failed, the URL, PostgreSQL's message):
// ALREADY_EXISTS (23505 unique violation), DEADLINE_EXCEEDED (57014
// statement timeout), ABORTED (40001 serialisation failure, 40P01
// deadlock), UNAVAILABLE (57P.. shutting down, 08... connection),
// RESOURCE_EXHAUSTED with the error reason DATABASE_FULL (53100 disk_full:
// "could not extend file ...: No space left on device"; nothing was
// written and the same statement succeeds once space is freed), INTERNAL
// (anything else).
absl::Status PgStatementError(std::string_view sqlstate, const std::string& text);

// One borrowed connection, for statements that must share a session (a
// transaction).
class PgSession {
 public:
  // Runs `sql` with `params`. Errors: UNAVAILABLE (connection lost), else
  // PgStatementError's, each naming `what` and the redacted URL.
  absl::StatusOr<PgRows> Exec(const std::string& what, const std::string& sql, const PgParams& params = {});
  pg_conn* raw() const { return conn_; }

 private:
  friend class PgConnectionPool;
  PgSession(pg_conn* conn, const std::string* url) : conn_(conn), url_(url) {}
  pg_conn* conn_;
  const std::string* url_;  // redacted
};

class PgConnectionPool {
 public:
  struct Options {
    std::string url;
    int size = 8;
    int statement_timeout_ms = 10'000;
    int64_t reconnect_window_ms = 30'000;
    // A connection into a dead link is given up after about this long
    // (connect, statement or idle); see pg_dead_link.h.
    int dead_link_seconds = kDefaultDeadLinkSeconds;
  };
  // Connects once to check the URL: UNAVAILABLE naming the redacted URL
  // and libpq's reason when the database cannot be reached.
  static absl::StatusOr<std::unique_ptr<PgConnectionPool>> Open(const Options& options);
  ~PgConnectionPool();

  // Runs `body` on one connection. When the connection turns out broken
  // (UNAVAILABLE), the connection is re-made and `body` runs again from the
  // start, until `reconnect_window_ms` has passed; so `body` must be
  // restartable (a whole transaction, or one statement).
  absl::Status Run(const std::function<absl::Status(PgSession&)>& body);
  // One statement through Run.
  absl::StatusOr<PgRows> Exec(const std::string& what, const std::string& sql, const PgParams& params = {});
  // `body` inside BEGIN ... COMMIT (ROLLBACK when it fails), through Run.
  absl::Status Transaction(const std::function<absl::Status(PgSession&)>& body);

  // A fresh connection outside the pool (LISTEN, advisory locks), with
  // the statement timeout and the dead-link settings. Caller owns it (PQfinish).
  absl::StatusOr<pg_conn*> Connect() const;

  // Whether the database answers SELECT 1 within `timeout_ms`, on a
  // connection of the probe's own (kept between probes): never queued
  // behind the pool's statements or their reconnect window, and bounded
  // however the link fails (refused, black-holed, a hung server). OK, or
  // UNAVAILABLE naming the redacted URL and why. Feeds Outage().
  absl::Status Probe(int timeout_ms);
  // UNAVAILABLE ("unreachable for N s: WHY") from the moment a reconnect
  // or a probe fails until a statement or a probe succeeds; OK otherwise.
  absl::Status Outage() const;
  // How many outages have ended: the database became reachable again after
  // a reconnect, a probe or a connection outside the pool failed. Workers'
  // heartbeats could not be recorded meanwhile (see BakeScheduler's lease
  // sweep).
  uint64_t OutagesRecovered() const;
  // For connections outside the pool (the maintenance lock's): a statement
  // on one failed for want of the database, or one succeeded.
  void NoteUnreachable(const absl::Status& why);
  void NoteReachable();
  const std::string& redacted_url() const { return redacted_url_; }

 private:
  explicit PgConnectionPool(Options options);
  absl::StatusOr<pg_conn*> Borrow();
  void Return(pg_conn* conn);
  // The libpq keywords and values every connection is made with.
  std::vector<std::pair<std::string, std::string>> ConnectParams() const;

  const Options options_;
  const std::string redacted_url_;
  std::mutex mu_;
  std::condition_variable available_;
  std::vector<pg_conn*> idle_;
  int open_ = 0;  // connections made and not closed (idle + borrowed)

  std::mutex probe_mu_;  // one probe at a time, on probe_conn_
  pg_conn* probe_conn_ = nullptr;
  mutable std::mutex outage_mu_;
  std::chrono::steady_clock::time_point unreachable_since_;  // meaningful while unreachable_
  bool unreachable_ = false;
  std::string unreachable_why_;
  uint64_t outages_recovered_ = 0;  // guarded by outage_mu_
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_STORE_POSTGRES_PG_CONNECTION_POOL_H_
