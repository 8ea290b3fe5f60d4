// PgConnectionPool's health: a bounded probe on a connection of its own,
// and the outage state that read-only callers check before queueing.
//
// Why not a pool statement: Run waits out a reconnect window (30 s by
// default) and a statement sent into a dead link waits for the dead-link
// timeout (20 s); a readiness probe must answer within its own budget
// (Kubernetes gives it seconds). So the probe drives libpq's non-blocking
// connect and query with poll() against one deadline.
#include <libpq-fe.h>
#include <poll.h>

#include <cerrno>
#include <chrono>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "server/store/postgres/pg_connection_pool.h"
#include "server/store/postgres/libpq_args.h"

namespace impostor {
namespace {

using Clock = std::chrono::steady_clock;

// Waits until `fd` is ready for `events`; false when `deadline` passes first.
bool WaitFor(int fd, short events, Clock::time_point deadline) {
  while (true) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0 || fd < 0) return false;
    pollfd p{fd, events, 0};
    const int r = poll(&p, 1, static_cast<int>(left));
    if (r > 0) return true;
    if (r == 0) return false;
    if (errno != EINTR) return false;
  }
}

// Connects without blocking past `deadline` (a host name is still resolved
// synchronously by libpq; an address that never answers is not waited on).
absl::StatusOr<PGconn*> ConnectBefore(const std::vector<std::pair<std::string, std::string>>& params,
                                      Clock::time_point deadline, int timeout_ms) {
  const LibpqKeywords args(params);
  PGconn* conn = PQconnectStartParams(args.keywords(), args.values(), /*expand_dbname=*/1);
  if (conn == nullptr) return absl::UnavailableError("cannot connect: out of memory");
  PostgresPollingStatusType st = PGRES_POLLING_WRITING;
  while (PQstatus(conn) != CONNECTION_BAD && st != PGRES_POLLING_OK && st != PGRES_POLLING_FAILED) {
    if (!WaitFor(PQsocket(conn), st == PGRES_POLLING_READING ? POLLIN : POLLOUT, deadline)) {
      PQfinish(conn);
      return absl::UnavailableError(absl::StrCat("cannot connect: no answer within ", timeout_ms, " ms"));
    }
    st = PQconnectPoll(conn);
  }
  if (PQstatus(conn) != CONNECTION_OK) {
    const std::string why = LibpqMessageLine(PQerrorMessage(conn));
    PQfinish(conn);
    return absl::UnavailableError(absl::StrCat("cannot connect: ", why));
  }
  PQsetNoticeProcessor(conn, [](void*, const char*) {}, nullptr);
  return conn;
}

// SELECT 1 on `conn`, answered before `deadline`.
absl::Status SelectOneBefore(PGconn* conn, Clock::time_point deadline, int timeout_ms) {
  if (PQsendQuery(conn, "SELECT 1") == 0) {
    return absl::UnavailableError(absl::StrCat("SELECT 1: ", LibpqMessageLine(PQerrorMessage(conn))));
  }
  bool answered = false;
  std::string error;
  while (true) {
    while (PQisBusy(conn) == 0) {
      PGresult* r = PQgetResult(conn);
      if (r == nullptr) {
        if (answered) return absl::OkStatus();
        return absl::UnavailableError(absl::StrCat("SELECT 1: ", error.empty() ? "no result" : error));
      }
      if (PQresultStatus(r) == PGRES_TUPLES_OK) {
        answered = true;
      } else {
        error = LibpqMessageLine(PQresultErrorMessage(r));
      }
      PQclear(r);
    }
    if (!WaitFor(PQsocket(conn), POLLIN, deadline)) {
      return absl::UnavailableError(absl::StrCat("SELECT 1: no answer within ", timeout_ms, " ms"));
    }
    if (PQconsumeInput(conn) == 0) {
      return absl::UnavailableError(absl::StrCat("SELECT 1: ", LibpqMessageLine(PQerrorMessage(conn))));
    }
  }
}

}  // namespace

absl::Status PgConnectionPool::Probe(int timeout_ms) {
  std::lock_guard lock(probe_mu_);
  const auto deadline = Clock::now() + std::chrono::milliseconds(timeout_ms);
  absl::Status status;
  // A kept connection may have died with a database restart since the last
  // probe (it reads as fine until used): one failure on it earns one fresh
  // connection within the same deadline, so a restarted database that
  // answers is not reported down.
  for (int attempt = 0; attempt < 2; ++attempt) {
    const bool fresh = probe_conn_ == nullptr || PQstatus(probe_conn_) != CONNECTION_OK;
    status = absl::OkStatus();
    if (fresh) {
      if (probe_conn_ != nullptr) PQfinish(probe_conn_);
      probe_conn_ = nullptr;
      auto conn = ConnectBefore(ConnectParams(), deadline, timeout_ms);
      if (conn.ok()) {
        probe_conn_ = *conn;
      } else {
        status = conn.status();
      }
    }
    if (status.ok()) status = SelectOneBefore(probe_conn_, deadline, timeout_ms);
    if (status.ok() || fresh || Clock::now() >= deadline) break;
    PQfinish(probe_conn_);
    probe_conn_ = nullptr;
  }
  if (status.ok()) {
    NoteReachable();
    return status;
  }
  // A half-answered query leaves the connection unusable: start afresh.
  if (probe_conn_ != nullptr) PQfinish(probe_conn_);
  probe_conn_ = nullptr;
  status = absl::UnavailableError(absl::StrCat("postgresql probe (", redacted_url_, "): ", status.message()));
  NoteUnreachable(status);
  return status;
}

void PgConnectionPool::NoteReachable() {
  std::lock_guard lock(outage_mu_);
  if (!unreachable_) return;
  unreachable_ = false;
  ++outages_recovered_;
  const double seconds = std::chrono::duration<double>(Clock::now() - unreachable_since_).count();
  spdlog::info("event=database_reachable url={} unreachable_seconds={:.1f}", redacted_url_, seconds);
}

void PgConnectionPool::NoteUnreachable(const absl::Status& why) {
  std::lock_guard lock(outage_mu_);
  unreachable_why_ = std::string(why.message());
  if (unreachable_) return;
  unreachable_ = true;
  unreachable_since_ = Clock::now();
}

uint64_t PgConnectionPool::OutagesRecovered() const {
  std::lock_guard lock(outage_mu_);
  return outages_recovered_;
}

absl::Status PgConnectionPool::Outage() const {
  std::lock_guard lock(outage_mu_);
  if (!unreachable_) return absl::OkStatus();
  const double seconds = std::chrono::duration<double>(Clock::now() - unreachable_since_).count();
  return absl::UnavailableError(
      absl::StrCat("job database unreachable for ", static_cast<int64_t>(seconds), " s: ", unreachable_why_));
}

}  // namespace impostor
