// The wording of a full-disk error and the free-space probe behind it, and
// how each database engine's "disk full" becomes one (the full disk itself:
// tests/integration/disk_full_test.cc, database_full_worker_test.cc).
#include "server/blobs/disk_full.h"

#include <sqlite3.h>
#include <unistd.h>

#include <cerrno>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "common/error_reason.h"
#include "server/store/postgres/pg_connection_pool.h"
#include "server/store/sqlite/sqlite_open.h"

namespace impostor {
namespace {

TEST(DiskFullError, OnlyNoSpaceAndQuotaCount) {
  EXPECT_TRUE(IsDiskFull(ENOSPC));
  EXPECT_TRUE(IsDiskFull(EDQUOT));
  for (int other : {0, EIO, EACCES, EROFS, ENOENT}) EXPECT_FALSE(IsDiskFull(other)) << other;
}

TEST(DiskFullError, FreeBytesAsksTheNearestExistingFolder) {
  const std::filesystem::path tmp = std::filesystem::temp_directory_path();
  const int64_t here = FreeBytes(tmp);
  EXPECT_GT(here, 0);
  // A file not yet created is on its folder's filesystem.
  EXPECT_GT(FreeBytes(tmp / "not-created-yet" / "blob.tmp"), 0);
}

TEST(DiskFullError, TheErrorNamesThePathTheCauseAndTheFreeSpace) {
  const std::filesystem::path file = std::filesystem::temp_directory_path() / "x.tmp";
  const absl::Status s = DiskFullError("write", file, "No space left on device");
  EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted);
  const std::string m(s.message());
  EXPECT_EQ(m.rfind("write " + file.string() + ": No space left on device (", 0), 0u) << m;
  EXPECT_NE(m.find(" bytes free on its filesystem); free space or raise the quota"), std::string::npos) << m;
}

// SQLite says SQLITE_FULL for a full disk and for a database at its
// max_page_count: the latter stands in for the former here.
TEST(DiskFullError, SqliteFullIsResourceExhaustedDatabaseFullNamingTheFile) {
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / ("disk_full_error_" + std::to_string(::getpid()) + ".sqlite3");
  std::filesystem::remove(file);
  auto db = OpenSqliteDatabase(file, "CREATE TABLE t (b BLOB); PRAGMA max_page_count = 4;");
  ASSERT_TRUE(db.ok()) << db.status();
  {
    SqliteStatement insert(*db, "INSERT INTO t (b) VALUES (?1)", "test store");
    ASSERT_TRUE(insert.prepared().ok());
    insert.BindBlob(1, std::string(64 << 10, 'x'));
    ASSERT_EQ(insert.Step(), SQLITE_FULL);
    const absl::Status s = insert.Error("insert");
    EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted) << s;
    EXPECT_EQ(ErrorReasonOf(s), error_reason::kDatabaseFull) << s;
    const std::string m(s.message());
    EXPECT_EQ(m.rfind("test store insert: " + file.string() + ": database or disk is full (", 0), 0u) << m;
    EXPECT_NE(m.find(" bytes free on its filesystem)"), std::string::npos) << m;
  }
  {
    // Any other failure stays INTERNAL, with no reason.
    SqliteStatement bad(*db, "INSERT INTO missing (b) VALUES (1)", "test store");
    const absl::Status s = bad.prepared();
    EXPECT_EQ(s.code(), absl::StatusCode::kInternal) << s;
    EXPECT_EQ(ErrorReasonOf(s), "") << s;
  }
  sqlite3_close(*db);
  std::filesystem::remove(file);
}

TEST(DiskFullError, PostgresSqlstatesMapToCodesAndOnlyDiskFullCarriesDatabaseFull) {
  struct Case {
    const char* sqlstate;
    absl::StatusCode code;
    const char* reason;
  };
  const Case cases[] = {
      {"53100", absl::StatusCode::kResourceExhausted, error_reason::kDatabaseFull},  // disk_full
      {"53200", absl::StatusCode::kInternal, ""},                                    // out_of_memory
      {"23505", absl::StatusCode::kAlreadyExists, ""},
      {"57014", absl::StatusCode::kDeadlineExceeded, ""},
      {"40001", absl::StatusCode::kAborted, ""},
      {"57P01", absl::StatusCode::kUnavailable, ""},
      {"08006", absl::StatusCode::kUnavailable, ""},
      {"", absl::StatusCode::kInternal, ""},
  };
  const std::string text = "postgresql update job (postgresql://h/db): could not extend file \"base/1/2\": No space "
                           "left on device";
  for (const Case& c : cases) {
    const absl::Status s = PgStatementError(c.sqlstate, text);
    EXPECT_EQ(s.code(), c.code) << "SQLSTATE " << c.sqlstate << ": " << s;
    EXPECT_EQ(ErrorReasonOf(s), c.reason) << "SQLSTATE " << c.sqlstate;
    EXPECT_EQ(std::string(s.message()).rfind(text, 0), 0u) << "SQLSTATE " << c.sqlstate << ": " << s;
  }
}

}  // namespace
}  // namespace impostor
