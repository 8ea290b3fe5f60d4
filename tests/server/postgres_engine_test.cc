// What only the engine choice and the PostgreSQL engine add to the JobStore
// contract: the --database factory, schema versions refused when newer than
// the binary (both engines), errors that name the URL without its password,
// statement timeouts, reconnecting across a database restart, the
// maintenance lock passing between servers, and NOTIFY wake-ups.
#include <sqlite3.h>

#include <condition_variable>
#include <mutex>

#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "server/store/job_store_factory.h"
#include "server/store/postgres/pg_connection_pool.h"
#include "server/store/postgres/pg_url.h"
#include "server/store/sqlite/sqlite_job_store.h"
#include "tests/server/job_store_test_engines.h"

namespace impostor::testing {
namespace {

JobRecord QueuedJob(const std::string& id) {
  JobRecord r;
  r.job.set_job_id(id);
  r.job.set_cache_key("key-" + id);
  r.job.set_state(v1::JOB_STATE_QUEUED);
  r.job.set_created_ms(1);
  return r;
}

TEST(RedactDatabaseUrl, HidesPasswordsOnly) {
  EXPECT_EQ(RedactDatabaseUrl("postgresql://farm:s3cret@db.example:5432/jobs"),
            "postgresql://farm:***@db.example:5432/jobs");
  EXPECT_EQ(RedactDatabaseUrl("postgres://farm:p@ss@db/jobs?sslmode=require"), "postgres://farm:***@db/jobs?sslmode=require");
  EXPECT_EQ(RedactDatabaseUrl("postgresql://db/jobs?user=farm&password=s3cret&sslmode=require"),
            "postgresql://db/jobs?user=farm&password=***&sslmode=require");
  EXPECT_EQ(RedactDatabaseUrl("postgresql://farm@/jobs?host=/run/pg"), "postgresql://farm@/jobs?host=/run/pg");
}

TEST(OpenJobStore, RefusesAnotherSchemeNamingTheFlag) {
  auto store = OpenJobStore({.database_url = "mysql://root:pw@db/jobs"});
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(store.status().message().find("--database"), std::string::npos) << store.status();
  EXPECT_EQ(store.status().message().find("pw@"), std::string::npos) << store.status();
  auto no_dir = OpenJobStore({});
  EXPECT_EQ(no_dir.status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(OpenJobStore, WithoutDatabaseIsSqliteInTheDataDirectory) {
  const auto dir = std::filesystem::temp_directory_path() / ("factory_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  auto store = OpenJobStore({.data_dir = dir.string()});
  ASSERT_TRUE(store.ok()) << store.status();
  EXPECT_TRUE(std::filesystem::exists(dir / "jobs.sqlite3"));
  std::filesystem::remove_all(dir);
}

TEST(OpenJobStore, UnreachableDatabaseIsNamedWithoutItsPassword) {
  // Port 1 on loopback: refused at once.
  auto store = OpenJobStore({.database_url = "postgresql://farm:hunter2@127.0.0.1:1/jobs?connect_timeout=5"});
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.status().code(), absl::StatusCode::kUnavailable) << store.status();
  const std::string message(store.status().message());
  EXPECT_NE(message.find("postgresql://farm:***@127.0.0.1:1/jobs"), std::string::npos) << message;
  EXPECT_EQ(message.find("hunter2"), std::string::npos) << message;
}

TEST(PostgresEngine, NewerSchemaIsRefused) {
  const std::string url = FreshPostgresDatabase();
  ASSERT_FALSE(url.empty());
  ASSERT_TRUE(PostgresJobStore::Open({.url = url}).ok());
  const std::string db = DatabaseName(url);
  ASSERT_TRUE(SharedPostgres()->Query(db, "UPDATE schema_version SET version = 99").ok());
  auto again = PostgresJobStore::Open({.url = url});
  ASSERT_FALSE(again.ok());
  EXPECT_EQ(again.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(again.status().message().find("schema version 99 is newer"), std::string::npos) << again.status();
  // The versions this binary knows open again.
  ASSERT_TRUE(SharedPostgres()->Query(db, absl::StrCat("UPDATE schema_version SET version = ",
                                                       PostgresSchemaVersion())).ok());
  EXPECT_TRUE(PostgresJobStore::Open({.url = url}).ok());
}

TEST(SqliteEngine, NewerSchemaIsRefused) {
  const auto dir = std::filesystem::temp_directory_path() / ("sqlite_version_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto file = dir / "jobs.sqlite3";
  ASSERT_TRUE(SqliteJobStore::Open(file).ok());
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "UPDATE schema_version SET version = 42", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  auto again = SqliteJobStore::Open(file);
  ASSERT_FALSE(again.ok());
  EXPECT_EQ(again.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(again.status().message().find("schema version 42 is newer"), std::string::npos) << again.status();
  std::filesystem::remove_all(dir);
}

TEST(PostgresEngine, StatementTimeoutEndsASlowStatement) {
  const std::string url = FreshPostgresDatabase();
  ASSERT_FALSE(url.empty());
  auto pool = PgConnectionPool::Open({.url = url, .size = 1, .statement_timeout_ms = 100});
  ASSERT_TRUE(pool.ok()) << pool.status();
  auto slow = (*pool)->Exec("sleep", "SELECT pg_sleep(30)");
  EXPECT_EQ(slow.status().code(), absl::StatusCode::kDeadlineExceeded) << slow.status();
  // The connection is still good for the next statement.
  auto quick = (*pool)->Exec("select", "SELECT 1");
  ASSERT_TRUE(quick.ok()) << quick.status();
  EXPECT_EQ(quick->Int(0, 0), 1);
}

TEST(PostgresEngine, ADatabaseRestartCostsAReconnectNotAJob) {
  // Its own server: restarting the shared one would disturb other tests.
  auto pg = PostgresInstance::Start();
  ASSERT_TRUE(pg.ok()) << pg.status();
  ASSERT_TRUE((*pg)->CreateDatabase("jobs").ok());
  auto store = PostgresJobStore::Open({.url = (*pg)->Url("jobs"), .pool_size = 2});
  ASSERT_TRUE(store.ok()) << store.status();
  ASSERT_TRUE((*store)->Insert(QueuedJob("job-before")).ok());
  ASSERT_TRUE((*pg)->Restart().ok());
  // Every pooled connection is dead now; the next calls reconnect.
  auto before = (*store)->Get("job-before");
  ASSERT_TRUE(before.ok()) << before.status();
  EXPECT_TRUE(before->has_value());
  ASSERT_TRUE((*store)->Insert(QueuedJob("job-after")).ok());
  auto claimed = (*store)->ClaimQueued({"job-before"}, {.lease_id = "l1", .worker_id = "w"});
  ASSERT_TRUE(claimed.ok()) << claimed.status();
  EXPECT_TRUE(claimed->has_value());
  EXPECT_EQ(*(*store)->CountPending(""), 2);
}

TEST(PostgresEngine, MaintenanceLockPassesToTheNextServerWhenTheHolderGoes) {
  const std::string url = FreshPostgresDatabase();
  ASSERT_FALSE(url.empty());
  auto a = PostgresJobStore::Open({.url = url, .pool_size = 1});
  auto b = PostgresJobStore::Open({.url = url, .pool_size = 1});
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_TRUE(*(*a)->HoldMaintenanceLock());
  EXPECT_FALSE(*(*b)->HoldMaintenanceLock());
  EXPECT_TRUE(*(*a)->HoldMaintenanceLock());
  a->reset();  // the holder goes away (its session ends)
  // Blocks until the old session has released the lock, then lets go.
  const std::string db = DatabaseName(url);
  const std::string key = std::to_string(PostgresMaintenanceLockKey());
  ASSERT_TRUE(SharedPostgres()
                  ->Query(db, absl::StrCat("SELECT pg_advisory_lock(", key, "); SELECT pg_advisory_unlock(", key, ")"))
                  .ok());
  EXPECT_TRUE(*(*b)->HoldMaintenanceLock());
}

TEST(PostgresEngine, AChangeOnOneServerWakesTheOther) {
  const std::string url = FreshPostgresDatabase();
  ASSERT_FALSE(url.empty());
  auto a = PostgresJobStore::Open({.url = url, .pool_size = 1});
  auto b = PostgresJobStore::Open({.url = url, .pool_size = 1});
  ASSERT_TRUE(a.ok() && b.ok());
  std::mutex mu;
  std::condition_variable cv;
  int wakes = 0;
  (*a)->SetChangeCallback([&] {
    std::lock_guard lock(mu);
    ++wakes;
    cv.notify_all();
  });
  ASSERT_TRUE((*b)->Insert(QueuedJob("job-1")).ok());
  std::unique_lock lock(mu);
  // A generous limit for a loaded machine; the wake normally takes ms.
  EXPECT_TRUE(cv.wait_for(lock, std::chrono::seconds(60), [&] { return wakes > 0; }));
  lock.unlock();
  (*a)->SetChangeCallback(nullptr);
}

}  // namespace
}  // namespace impostor::testing
