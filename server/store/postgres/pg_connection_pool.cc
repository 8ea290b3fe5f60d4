#include "server/store/postgres/pg_connection_pool.h"

#include <libpq-fe.h>

#include <algorithm>
#include <chrono>
#include <optional>
#include <thread>
#include <vector>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "common/error_reason.h"
#include "server/store/database_full.h"
#include "server/store/postgres/libpq_args.h"
#include "server/store/postgres/pg_url.h"

namespace impostor {

PgParams& PgParams::TextArray(const std::vector<std::string>& items) {
  std::string v = "{";
  for (size_t i = 0; i < items.size(); ++i) {
    if (i > 0) v += ',';
    v += '"';
    for (char c : items[i]) {
      if (c == '"' || c == '\\') v += '\\';
      v += c;
    }
    v += '"';
  }
  v += '}';
  return Add(std::move(v), 0);
}

void PgRows::Clear(pg_result* r) { PQclear(r); }
int PgRows::size() const { return PQntuples(r_.get()); }
int PgRows::changed() const {
  const char* n = PQcmdTuples(r_.get());
  return n && *n ? std::atoi(n) : 0;
}
std::string PgRows::Text(int row, int col) const {
  return std::string(PQgetvalue(r_.get(), row, col), static_cast<size_t>(PQgetlength(r_.get(), row, col)));
}
int64_t PgRows::Int(int row, int col) const { return std::strtoll(PQgetvalue(r_.get(), row, col), nullptr, 10); }
bool PgRows::IsNull(int row, int col) const { return PQgetisnull(r_.get(), row, col) != 0; }
std::string PgRows::Bytes(int row, int col) const {
  size_t n = 0;
  unsigned char* raw =
      PQunescapeBytea(reinterpret_cast<const unsigned char*>(PQgetvalue(r_.get(), row, col)), &n);
  if (raw == nullptr) return std::string();
  std::string out(reinterpret_cast<const char*>(raw), n);
  PQfreemem(raw);
  return out;
}

absl::StatusOr<PgRows> PgSession::Exec(const std::string& what, const std::string& sql, const PgParams& params) {
  std::vector<const char*> values;
  std::vector<int> lengths;
  for (const std::string& v : params.values()) {
    values.push_back(v.data());
    lengths.push_back(static_cast<int>(v.size()));
  }
  // Without parameters, the simple protocol: it also runs several
  // statements at once (migrations).
  PGresult* r = params.size() == 0 ? PQexec(conn_, sql.c_str())
                                   : PQexecParams(conn_, sql.c_str(), static_cast<int>(params.size()), nullptr,
                                                  values.data(), lengths.data(), params.formats().data(), 0);
  PgRows rows(r);
  const ExecStatusType st = r ? PQresultStatus(r) : PGRES_FATAL_ERROR;
  if (st == PGRES_COMMAND_OK || st == PGRES_TUPLES_OK) return rows;
  const std::string message = r && PQresultErrorMessage(r)[0] ? PQresultErrorMessage(r) : PQerrorMessage(conn_);
  const std::string text = absl::StrCat("postgresql ", what, " (", *url_, "): ", LibpqMessageLine(message));
  if (PQstatus(conn_) == CONNECTION_BAD) return absl::UnavailableError(text);
  const char* state = r ? PQresultErrorField(r, PG_DIAG_SQLSTATE) : nullptr;
  return PgStatementError(state ? state : "", text);
}

absl::Status PgStatementError(std::string_view code, const std::string& text) {
  if (code == "23505") return absl::AlreadyExistsError(text);
  if (code == "57014") return absl::DeadlineExceededError(text);
  if (code == "40001" || code == "40P01") return absl::AbortedError(text);
  // The server is shutting down or restarting (admin_shutdown, crash
  // shutdown, cannot_connect_now): the connection is going away.
  if (code.rfind("57P", 0) == 0 || code.rfind("08", 0) == 0) return absl::UnavailableError(text);
  // disk_full: the database server's disk, which this server cannot
  // measure; PostgreSQL's message names the file it could not extend.
  if (code == "53100") {
    DatabaseFullRefusals().fetch_add(1, std::memory_order_relaxed);
    return WithErrorReason(absl::ResourceExhaustedError(absl::StrCat(
                               text, "; free space on the database server's disk: the server recovers by itself")),
                           error_reason::kDatabaseFull);
  }
  return absl::InternalError(text);
}

PgConnectionPool::PgConnectionPool(Options options)
    : options_(std::move(options)), redacted_url_(RedactDatabaseUrl(options_.url)) {}

PgConnectionPool::~PgConnectionPool() {
  std::lock_guard lock(mu_);
  for (pg_conn* c : idle_) PQfinish(c);
  std::lock_guard probe_lock(probe_mu_);
  if (probe_conn_ != nullptr) PQfinish(probe_conn_);
}

absl::StatusOr<std::unique_ptr<PgConnectionPool>> PgConnectionPool::Open(const Options& options) {
  std::unique_ptr<PgConnectionPool> pool(new PgConnectionPool(options));
  auto conn = pool->Connect();
  if (!conn.ok()) return conn.status();
  pool->idle_.push_back(*conn);
  pool->open_ = 1;
  return pool;
}

std::vector<std::pair<std::string, std::string>> PgConnectionPool::ConnectParams() const {
  // The dead-link keywords go before the URL (expanded as "dbname"), so
  // that keywords the URL sets itself win (libpq: the last value counts).
  auto params = DeadLinkConnectParams(DeadLinkSettings(options_.dead_link_seconds));
  params.emplace_back("dbname", options_.url);
  return params;
}

absl::StatusOr<pg_conn*> PgConnectionPool::Connect() const {
  const PgDeadLinkSettings link = DeadLinkSettings(options_.dead_link_seconds);
  const auto params = ConnectParams();
  const LibpqKeywords args(params);
  PGconn* conn = PQconnectdbParams(args.keywords(), args.values(), /*expand_dbname=*/1);
  if (conn == nullptr || PQstatus(conn) != CONNECTION_OK) {
    const std::string why = conn ? LibpqMessageLine(PQerrorMessage(conn)) : "out of memory";
    PQfinish(conn);
    return absl::UnavailableError(absl::StrCat("--database: cannot connect to ", redacted_url_, ": ", why));
  }
  // Quiet NOTICEs (e.g. "relation already exists, skipping").
  PQsetNoticeProcessor(conn, [](void*, const char*) {}, nullptr);
  // Several statements in one simple query; the last one's result is
  // returned, and any failure fails the whole.
  const std::string setup = absl::StrCat("SET statement_timeout = ", options_.statement_timeout_ms,
                                         "; SET application_name = 'impostor-server'; ", DeadLinkSessionSql(link));
  PGresult* r = PQexec(conn, setup.c_str());
  const bool ok = r && PQresultStatus(r) == PGRES_TUPLES_OK;
  PQclear(r);
  if (!ok) {
    const std::string why = LibpqMessageLine(PQerrorMessage(conn));
    PQfinish(conn);
    return absl::UnavailableError(absl::StrCat("--database: ", redacted_url_, ": session setup failed: ", why));
  }
  return conn;
}

absl::StatusOr<pg_conn*> PgConnectionPool::Borrow() {
  std::unique_lock lock(mu_);
  available_.wait(lock, [&] { return !idle_.empty() || open_ < options_.size; });
  if (!idle_.empty()) {
    pg_conn* c = idle_.back();
    idle_.pop_back();
    return c;
  }
  ++open_;
  lock.unlock();
  auto c = Connect();
  if (!c.ok()) {
    lock.lock();
    --open_;
    available_.notify_one();
  }
  return c;
}

void PgConnectionPool::Return(pg_conn* conn) {
  std::lock_guard lock(mu_);
  if (conn != nullptr && PQstatus(conn) == CONNECTION_OK && PQtransactionStatus(conn) == PQTRANS_IDLE) {
    idle_.push_back(conn);
  } else {
    PQfinish(conn);
    --open_;
  }
  available_.notify_one();
}

absl::Status PgConnectionPool::Run(const std::function<absl::Status(PgSession&)>& body) {
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::milliseconds(options_.reconnect_window_ms);
  auto backoff = std::chrono::milliseconds(50);
  int tries = 0;
  while (true) {
    ++tries;
    auto conn = Borrow();
    absl::Status status;
    if (!conn.ok()) {
      status = conn.status();
    } else {
      PgSession session(*conn, &redacted_url_);
      status = body(session);
      Return(*conn);
    }
    if (!absl::IsUnavailable(status)) {
      // Any answer, an error included, means the database is reachable.
      NoteReachable();
      if (tries > 1 && status.ok()) spdlog::info("event=database_reconnected url={} tries={}", redacted_url_, tries);
      return status;
    }
    // One broken connection is routine after a database restart (the next
    // try reconnects); a failed reconnect is an outage.
    if (tries > 1 || !conn.ok()) NoteUnreachable(status);
    if (std::chrono::steady_clock::now() >= give_up) return status;
    if (tries == 1) {
      spdlog::warn("event=database_unavailable url={} error=\"{}\" action=reconnect", redacted_url_,
                   std::string(status.message()));
    }
    // Backoff between reconnects (not synchronisation): the database is
    // restarting and needs a moment before it accepts connections.
    std::this_thread::sleep_for(backoff);
    backoff = std::min(backoff * 2, std::chrono::milliseconds(1000));
  }
}

absl::StatusOr<PgRows> PgConnectionPool::Exec(const std::string& what, const std::string& sql,
                                              const PgParams& params) {
  std::optional<PgRows> rows;
  absl::Status s = Run([&](PgSession& session) -> absl::Status {
    auto r = session.Exec(what, sql, params);
    if (!r.ok()) return r.status();
    rows.emplace(std::move(*r));
    return absl::OkStatus();
  });
  if (!s.ok()) return s;
  return std::move(*rows);
}

absl::Status PgConnectionPool::Transaction(const std::function<absl::Status(PgSession&)>& body) {
  return Run([&](PgSession& session) -> absl::Status {
    if (auto b = session.Exec("begin", "BEGIN"); !b.ok()) return b.status();
    absl::Status s = body(session);
    if (s.ok()) {
      auto c = session.Exec("commit", "COMMIT");
      return c.status();
    }
    if (PQstatus(session.raw()) == CONNECTION_OK) (void)session.Exec("rollback", "ROLLBACK");
    return s;
  });
}

}  // namespace impostor
