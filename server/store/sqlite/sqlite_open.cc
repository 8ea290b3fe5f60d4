#include "server/store/sqlite/sqlite_open.h"

#include "absl/strings/str_cat.h"
#include "common/error_reason.h"
#include "server/store/database_full.h"
#include "server/blobs/disk_full.h"

namespace impostor {

absl::StatusOr<sqlite3*> OpenSqliteDatabase(const std::filesystem::path& file, const char* schema) {
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(file.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX, nullptr) !=
      SQLITE_OK) {
    std::string msg = db ? sqlite3_errmsg(db) : "out of memory";
    sqlite3_close(db);
    return absl::InternalError(absl::StrCat("cannot open ", file.string(), ": ", msg));
  }
  sqlite3_busy_timeout(db, 5000);
  char* err = nullptr;
  if (sqlite3_exec(db, schema, nullptr, nullptr, &err) != SQLITE_OK) {
    std::string msg = err ? err : "unknown error";
    sqlite3_free(err);
    sqlite3_close(db);
    return absl::InternalError(absl::StrCat("cannot initialise ", file.string(), ": ", msg));
  }
  return db;
}

SqliteStatement::SqliteStatement(sqlite3* db, const char* sql, std::string_view store) : db_(db), store_(store) {
  rc_ = sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr);
}

std::string SqliteStatement::Text(int col) const {
  const auto* p = reinterpret_cast<const char*>(sqlite3_column_text(stmt_, col));
  return p ? std::string(p, static_cast<size_t>(sqlite3_column_bytes(stmt_, col))) : std::string();
}

std::string SqliteStatement::Blob(int col) const {
  const auto* p = static_cast<const char*>(sqlite3_column_blob(stmt_, col));
  return p ? std::string(p, static_cast<size_t>(sqlite3_column_bytes(stmt_, col))) : std::string();
}

absl::Status SqliteError(sqlite3* db, std::string_view store, std::string_view what) {
  if (sqlite3_errcode(db) == SQLITE_FULL) {
    DatabaseFullRefusals().fetch_add(1, std::memory_order_relaxed);
    const char* file = sqlite3_db_filename(db, "main");
    return WithErrorReason(DiskFullError(absl::StrCat(std::string(store), " ", std::string(what), ":"),
                                         file != nullptr && file[0] != '\0' ? file : "database", sqlite3_errmsg(db)),
                           error_reason::kDatabaseFull);
  }
  return absl::InternalError(absl::StrCat(std::string(store), " ", std::string(what), ": ", sqlite3_errmsg(db)));
}

}  // namespace impostor
