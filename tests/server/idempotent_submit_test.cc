// SubmitBakeRequest.request_id: a retried submit returns the job the first
// one created (also after a restart), per requester; malformed ids are
// refused naming the field; a database from before the column migrates.
#include <sqlite3.h>

#include <string>

#include <gtest/gtest.h>

#include "tests/server/scheduler_fixture.h"

namespace impostor {
namespace {

using IdempotentSubmitTest = testing_support::SchedulerFixture;

v1::SubmitBakeRequest WithId(v1::SubmitBakeRequest r, const std::string& id) {
  r.set_request_id(id);
  return r;
}

TEST_F(IdempotentSubmitTest, ARetriedSubmitReturnsTheFirstJob) {
  const v1::SubmitBakeRequest request = WithId(Request("tree"), "retry-0123456789abcdef");
  const v1::SubmitBakeResponse first = Submit(request, "ci-1");
  const v1::SubmitBakeResponse again = Submit(request, "ci-1");
  ASSERT_FALSE(first.job_id().empty());
  EXPECT_EQ(again.job_id(), first.job_id());
  EXPECT_EQ(again.cache_key(), first.cache_key());
  EXPECT_EQ(again.job().state(), v1::JOB_STATE_QUEUED);
  EXPECT_EQ(*jobs_->CountPending(""), 1) << "the retry must not queue a second job";
}

TEST_F(IdempotentSubmitTest, TheFirstJobIsFoundAfterARestart) {
  const v1::SubmitBakeRequest request = WithId(Request("tree"), "restart_id");
  const v1::SubmitBakeResponse first = Submit(request, "ci-1");
  const v1::LeasedJob leased = Lease();
  ASSERT_EQ(leased.job_id(), first.job_id());
  Reopen();
  const v1::SubmitBakeResponse again = Submit(request, "ci-1");
  EXPECT_EQ(again.job_id(), first.job_id());
  EXPECT_EQ(again.job().state(), v1::JOB_STATE_RUNNING) << "the retry sees the first job's progress";
  EXPECT_EQ(*jobs_->CountPending(""), 1);
}

TEST_F(IdempotentSubmitTest, AFinishedJobIsReturnedWithItsResult) {
  const v1::SubmitBakeRequest request = WithId(Request("tree"), "done-1");
  const v1::SubmitBakeResponse first = Submit(request, "ci-1");
  ASSERT_TRUE(scheduler_->Complete(Result(Lease())).ok());
  const v1::SubmitBakeResponse again = Submit(request, "ci-1");
  EXPECT_EQ(again.job_id(), first.job_id());
  EXPECT_EQ(again.job().state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(again.job().result().cache_key(), first.cache_key());
  EXPECT_FALSE(again.cached()) << "the first submit was a bake, not a cache hit";
}

TEST_F(IdempotentSubmitTest, ACacheHitRetryReturnsTheSameHit) {
  Submit(Request("tree"), "ci-1");
  ASSERT_TRUE(scheduler_->Complete(Result(Lease())).ok());
  const v1::SubmitBakeRequest request = WithId(Request("tree"), "hit-1");
  const v1::SubmitBakeResponse first = Submit(request, "ci-1");
  const v1::SubmitBakeResponse again = Submit(request, "ci-1");
  ASSERT_TRUE(first.cached());
  EXPECT_TRUE(again.cached());
  EXPECT_EQ(again.job_id(), first.job_id());
  EXPECT_TRUE(again.job().has_result());
}

TEST_F(IdempotentSubmitTest, ARetryOfASharedBakeReturnsTheSameFollower) {
  const v1::SubmitBakeResponse leader = Submit(WithId(Request("tree"), "first"), "ci-1");
  const v1::SubmitBakeRequest second = WithId(Request("tree"), "second");
  const v1::SubmitBakeResponse follower = Submit(second, "ci-1");
  ASSERT_NE(follower.job_id(), leader.job_id()) << "a new request id is a new requester of the same bake";
  EXPECT_EQ(Submit(second, "ci-1").job_id(), follower.job_id());
  EXPECT_EQ(*jobs_->CountPending(""), 2);
}

TEST_F(IdempotentSubmitTest, IdsArePerRequester) {
  const v1::SubmitBakeRequest request = WithId(Request("tree"), "same-id");
  const v1::SubmitBakeResponse a = Submit(request, "ci-1");
  const v1::SubmitBakeResponse b = Submit(request, "ci-2");
  EXPECT_NE(a.job_id(), b.job_id()) << "another client's id is not this client's retry";
  EXPECT_EQ(*jobs_->CountPending(""), 2);
}

TEST_F(IdempotentSubmitTest, NoIdMeansNoDeduplication) {
  const v1::SubmitBakeResponse a = Submit(Request("tree"), "ci-1");
  const v1::SubmitBakeResponse b = Submit(Request("tree"), "ci-1");
  EXPECT_NE(a.job_id(), b.job_id());
}

TEST_F(IdempotentSubmitTest, AnIdReusedForADifferentBakeIsRefused) {
  Submit(WithId(Request("tree"), "reused"), "ci-1");
  auto r = scheduler_->Submit(WithId(Request("rock"), "reused"), "ci-1");
  ASSERT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument) << r.status();
  EXPECT_NE(r.status().message().find("request_id"), std::string::npos) << r.status();
  EXPECT_NE(r.status().message().find("different mesh or parameters"), std::string::npos) << r.status();
}

TEST_F(IdempotentSubmitTest, MalformedIdsAreRefusedNamingTheField) {
  struct Case {
    const char* name;
    std::string id;
    const char* says;
  };
  const Case cases[] = {
      {"129 bytes", std::string(129, 'a'), "129 bytes is over the limit of 128"},
      {"space", "my id", "byte 2 (0x20)"},
      {"slash", "a/b", "byte 1 (0x2f)"},
      {"dot", "v1.2", "byte 2 (0x2e)"},
      {"non-ascii", "caf\xc3\xa9", "byte 3 (0xc3)"},
      {"nul", std::string("a\0b", 3), "byte 1 (0x00)"},
  };
  for (const Case& c : cases) {
    auto r = scheduler_->Submit(WithId(Request("tree"), c.id), "ci-1");
    EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument) << c.name;
    EXPECT_NE(r.status().message().find("request_id: "), std::string::npos) << c.name << ": " << r.status();
    EXPECT_NE(r.status().message().find(c.says), std::string::npos) << c.name << ": " << r.status();
  }
  EXPECT_EQ(*jobs_->CountPending(""), 0);
  // The longest and every allowed character pass.
  EXPECT_TRUE(scheduler_->Submit(WithId(Request("tree"), std::string(128, 'z')), "ci-1").ok());
  EXPECT_TRUE(scheduler_->Submit(WithId(Request("tree"), "AZaz09_-"), "ci-1").ok());
}

// A jobs table as the first release created it (no priority, request_id or
// lease_expiries columns), holding one queued job.
TEST(JobStoreMigration, AnOldDatabaseGainsTheNewColumnsAndKeepsItsJobs) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("job_store_migration_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::filesystem::path file = dir / "jobs.sqlite3";
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
    v1::Job job;
    job.set_job_id("job-old");
    job.set_cache_key(std::string(64, 'a'));
    job.set_state(v1::JOB_STATE_QUEUED);
    v1::SubmitBakeRequest request;
    request.mutable_mesh()->mutable_entry()->set_path("old.glb");
    const std::string sql =
        "CREATE TABLE jobs (job_id TEXT PRIMARY KEY, cache_key TEXT NOT NULL, state INTEGER NOT NULL, "
        "created_ms INTEGER NOT NULL, lease_id TEXT NOT NULL DEFAULT '', lease_deadline_ms INTEGER NOT NULL "
        "DEFAULT 0, worker_id TEXT NOT NULL DEFAULT '', job BLOB NOT NULL, request BLOB NOT NULL, leader_job_id "
        "TEXT NOT NULL DEFAULT '', requester_cancelled INTEGER NOT NULL DEFAULT 0, client_id TEXT NOT NULL "
        "DEFAULT '');";
    ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_stmt* st = nullptr;
    ASSERT_EQ(sqlite3_prepare_v2(db,
                                 "INSERT INTO jobs (job_id, cache_key, state, created_ms, job, request, client_id) "
                                 "VALUES ('job-old', ?1, 1, 5, ?2, ?3, 'ci-1')",
                                 -1, &st, nullptr),
              SQLITE_OK);
    const std::string job_bytes = job.SerializeAsString();
    const std::string request_bytes = request.SerializeAsString();
    sqlite3_bind_text(st, 1, job.cache_key().c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_bind_blob(st, 2, job_bytes.data(), static_cast<int>(job_bytes.size()), SQLITE_TRANSIENT);
    sqlite3_bind_blob(st, 3, request_bytes.data(), static_cast<int>(request_bytes.size()), SQLITE_TRANSIENT);
    ASSERT_EQ(sqlite3_step(st), SQLITE_DONE);
    sqlite3_finalize(st);
    sqlite3_close(db);
  }
  auto store = JobStore::Open(file);
  ASSERT_TRUE(store.ok()) << store.status();
  auto old = (*store)->Get("job-old");
  ASSERT_TRUE(old.ok() && old->has_value()) << old.status();
  EXPECT_EQ((*old)->mesh.entry().path(), "old.glb");
  EXPECT_EQ((*old)->request_id, "");
  EXPECT_EQ((*old)->lease_expiries, 0);
  // The new column works on the migrated table.
  JobRecord fresh;
  fresh.job.set_job_id("job-new");
  fresh.job.set_cache_key(std::string(64, 'b'));
  fresh.job.set_state(v1::JOB_STATE_QUEUED);
  fresh.client_id = "ci-1";
  fresh.request_id = "r-1";
  ASSERT_TRUE((*store)->Insert(fresh).ok());
  auto found = (*store)->FindByRequestId("ci-1", "r-1");
  ASSERT_TRUE(found.ok() && found->has_value());
  EXPECT_EQ((*found)->job.job_id(), "job-new");
  // The same (client, request id) twice is a bug the index refuses.
  fresh.job.set_job_id("job-dup");
  EXPECT_FALSE((*store)->Insert(fresh).ok());
  store->reset();
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace impostor
