// The two JobStore engines as test parameters: each Make() returns a fresh,
// empty store. SQLite: a file in a new temporary directory. PostgreSQL: a
// new database on one throwaway server per test binary
// (tests/support/postgres_instance.h), started on first use.
#ifndef IMPOSTOR_TESTS_SERVER_JOB_STORE_TEST_ENGINES_H_
#define IMPOSTOR_TESTS_SERVER_JOB_STORE_TEST_ENGINES_H_

#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "server/store/job_store.h"
#include "server/store/postgres/postgres_job_store.h"
#include "tests/support/postgres_instance.h"

namespace impostor::testing {

// The process-wide PostgreSQL server, started once (and stopped at exit).
inline PostgresInstance* SharedPostgres() {
  static std::unique_ptr<PostgresInstance> pg = [] {
    auto started = PostgresInstance::Start();
    if (!started.ok()) {
      ADD_FAILURE() << "cannot start PostgreSQL: " << started.status();
      return std::unique_ptr<PostgresInstance>();
    }
    return std::move(*started);
  }();
  return pg.get();
}

// A new, empty database on the shared server; its URL.
inline std::string FreshPostgresDatabase() {
  static std::atomic<int> next{0};
  PostgresInstance* pg = SharedPostgres();
  if (pg == nullptr) return "";
  const std::string name = "t" + std::to_string(::getpid()) + "_" + std::to_string(next++);
  auto s = pg->CreateDatabase(name);
  EXPECT_TRUE(s.ok()) << s;
  return pg->Url(name);
}

// The database name in a URL from FreshPostgresDatabase (for Query).
inline std::string DatabaseName(const std::string& url) {
  const size_t start = url.find("@/") + 2;
  return url.substr(start, url.find('?') - start);
}

struct SqliteEngine {
  static constexpr const char* kName = "sqlite";
  static absl::StatusOr<std::unique_ptr<JobStore>> Make() {
    static std::atomic<int> next{0};
    const auto dir = std::filesystem::temp_directory_path() /
                     ("job_store_contract_" + std::to_string(::getpid()) + "_" + std::to_string(next++));
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    return JobStore::Open(dir / "jobs.sqlite3");
  }
};

struct PostgresEngine {
  static constexpr const char* kName = "postgresql";
  static absl::StatusOr<std::unique_ptr<JobStore>> Make() {
    const std::string url = FreshPostgresDatabase();
    if (url.empty()) return absl::FailedPreconditionError("no PostgreSQL");
    auto store = PostgresJobStore::Open({.url = url, .pool_size = 4});
    if (!store.ok()) return store.status();
    return std::unique_ptr<JobStore>(std::move(*store));
  }
};

// Both engines, for TYPED_TEST_SUITE(Suite, JobStoreEngines, EngineNames):
// test names end in /sqlite and /postgresql.
using JobStoreEngines = ::testing::Types<SqliteEngine, PostgresEngine>;
struct EngineNames {
  template <typename T>
  static std::string GetName(int) {
    return T::kName;
  }
};

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_SERVER_JOB_STORE_TEST_ENGINES_H_
