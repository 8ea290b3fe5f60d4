// What every SQLite file of the server shares (jobs.sqlite3, tokens.sqlite3):
// how a connection is opened and a small prepared-statement wrapper.
//
// A connection from OpenSqliteDatabase is opened SQLITE_OPEN_NOMUTEX: its
// owner serialises every use of it (one mutex per store). It waits up to
// 5 s for another process's write (`impostor-server token ...` and
// `purge` run beside a running server) instead of failing at once.
#ifndef IMPOSTOR_SERVER_STORE_SQLITE_SQLITE_OPEN_H_
#define IMPOSTOR_SERVER_STORE_SQLITE_SQLITE_OPEN_H_

#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace impostor {

// Opens `file` read-write (creating it) and runs `schema` (PRAGMAs, CREATE
// ... IF NOT EXISTS). The caller owns the handle (sqlite3_close). INTERNAL
// "cannot open FILE: ..." or "cannot initialise FILE: ..." with SQLite's
// message.
absl::StatusOr<sqlite3*> OpenSqliteDatabase(const std::filesystem::path& file, const char* schema);

// The error of the last call on `db` that failed: RESOURCE_EXHAUSTED with
// the error reason DATABASE_FULL (common/error_reason.h), naming the
// database file and its filesystem's free space (DiskFullError), when
// SQLite found the disk or quota full (SQLITE_FULL; SQLite rolled the
// statement, or the transaction a failed COMMIT ended, back: nothing is
// half-written); else INTERNAL "<store> <what>: <SQLite's message>".
absl::Status SqliteError(sqlite3* db, std::string_view store, std::string_view what);

// RAII prepared statement for the stores' queries. Errors name the store
// (`store`, e.g. "token store") and SQLite's message.
class SqliteStatement {
 public:
  SqliteStatement(sqlite3* db, const char* sql, std::string_view store);
  ~SqliteStatement() { sqlite3_finalize(stmt_); }
  SqliteStatement(const SqliteStatement&) = delete;
  SqliteStatement& operator=(const SqliteStatement&) = delete;

  bool ok() const { return rc_ == SQLITE_OK; }
  // OK, or Error("prepare") when the statement did not compile.
  absl::Status prepared() const { return ok() ? absl::OkStatus() : Error("prepare"); }
  void Bind(int i, const std::string& v) {
    sqlite3_bind_text(stmt_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT);
  }
  void Bind(int i, int64_t v) { sqlite3_bind_int64(stmt_, i, v); }
  void BindBlob(int i, const std::string& v) {
    sqlite3_bind_blob(stmt_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT);
  }
  // SQLITE_ROW, SQLITE_DONE, or an error code.
  int Step() { return sqlite3_step(stmt_); }
  // Makes the statement ready to run again: ends the read it holds open
  // after a row and clears its bindings (a statement kept across calls).
  void Reset() {
    sqlite3_reset(stmt_);
    sqlite3_clear_bindings(stmt_);
  }
  std::string Text(int col) const;
  std::string Blob(int col) const;
  int64_t Int(int col) const { return sqlite3_column_int64(stmt_, col); }
  // SqliteError for this statement's connection: INTERNAL "<store> <what>:
  // <SQLite's message>", or RESOURCE_EXHAUSTED DATABASE_FULL naming the
  // database file and the free space when the disk is full.
  absl::Status Error(std::string_view what) const { return SqliteError(db_, store_, what); }

 private:
  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
  int rc_ = SQLITE_OK;
  std::string store_;
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_STORE_SQLITE_SQLITE_OPEN_H_
