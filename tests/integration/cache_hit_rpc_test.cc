// Issue 18 through a real server: a SubmitBake cache hit adds no row to the
// job database, and its job id still answers WatchJob and GetJob, also
// after the server restarts. Results are published through WorkerService
// (no worker, no GPU).
#include <sqlite3.h>

#include <string>

#include <gtest/gtest.h>

#include "tests/support/published_result.h"
#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

int64_t JobRows(const std::filesystem::path& data_dir) {
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open_v2((data_dir / "jobs.sqlite3").c_str(), &db, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  EXPECT_EQ(sqlite3_prepare_v2(db, "SELECT COUNT(*) FROM jobs", -1, &st, nullptr), SQLITE_OK);
  EXPECT_EQ(sqlite3_step(st), SQLITE_ROW);
  const int64_t n = sqlite3_column_int64(st, 0);
  sqlite3_finalize(st);
  sqlite3_close(db);
  return n;
}

TEST(CacheHitRpcTest, HitsAddNoRowAndTheirIdsAnswerWatchAndGetJob) {
  ServerProcess server(0);
  const std::string model = "glTF" + RandomBytes(64, 42);
  v1::SubmitBakeRequest submit;
  submit.mutable_mesh()->mutable_entry()->set_path("model.glb");
  *submit.mutable_mesh()->mutable_entry()->mutable_digest() = DigestOf(model);
  submit.mutable_parameters()->set_frames(3);
  submit.mutable_parameters()->set_resolution(64);
  ASSERT_TRUE(UploadBytes(server.assets(), model, submit.mesh().entry().digest()).ok());
  {
    v1::SubmitBakeResponse queued;
    ASSERT_TRUE(server.bake().SubmitBake(ContextWithin().get(), submit, &queued).ok());
    ASSERT_FALSE(queued.cached());
  }
  const PublishedResult published = CompleteNextJob(server, {1000, 2000, 1000}, 42);
  const int64_t rows = JobRows(server.data_dir());
  ASSERT_EQ(rows, 1);

  v1::SubmitBakeResponse hit;
  for (int i = 0; i < 10; ++i) {
    submit.set_request_id("hit-" + std::to_string(i));
    const grpc::Status s = server.bake().SubmitBake(ContextWithin().get(), submit, &hit);
    ASSERT_TRUE(s.ok()) << s.error_message();
    ASSERT_TRUE(hit.cached());
  }
  EXPECT_EQ(JobRows(server.data_dir()), rows) << "cache hits must not write job rows";

  const v1::Job watched = WatchToEnd(server.bake(), hit.job_id());
  EXPECT_EQ(watched.state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_TRUE(watched.cached());
  EXPECT_EQ(watched.result().cache_key(), published.key);

  server.Restart();
  v1::GetJobRequest get;
  get.set_job_id(hit.job_id());
  v1::Job job;
  const grpc::Status s = server.bake().GetJob(ContextWithin().get(), get, &job);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(job.state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(job.result().maps_size(), 3);

  // A made-up hit id for a key nothing was baked under is unknown.
  get.set_job_id("hit-" + std::string(64, 'a') + hit.job_id().substr(68));
  EXPECT_EQ(server.bake().GetJob(ContextWithin().get(), get, &job).error_code(), grpc::StatusCode::NOT_FOUND);
}

TEST(CacheHitRpcTest, OutOfRangeServingFlagsAreRefusedNamingTheFlag) {
  const std::filesystem::path data = NewTempDir("serving_flags");
  const struct {
    std::string flag;
    std::string message;
  } cases[] = {
      {"--job-retention-days=-1", "--job-retention-days: -1 is out of range 0..36500"},
      {"--job-retention-days=36501", "--job-retention-days: 36501 is out of range 0..36500"},
      {"--result-touch-flush-seconds=0", "--result-touch-flush-seconds: 0 is out of range 1..3600"},
      {"--result-touch-flush-seconds=3601", "--result-touch-flush-seconds: 3601 is out of range 1..3600"},
      {"--keepalive-seconds=0", "--keepalive-seconds: 0 is out of range 1..7200"},
      {"--keepalive-seconds=7201", "--keepalive-seconds: 7201 is out of range 1..7200"},
  };
  for (const auto& c : cases) {
    const ToolRun run = RunTool({(BinaryDir() / "impostor-server").string(), "--data=" + data.string(),
                                 "--listen=127.0.0.1:0", c.flag},
                                std::chrono::seconds(60));  // a server that accepted it would serve on
    EXPECT_EQ(run.exit_code, 2) << c.flag;
    EXPECT_NE(run.err.find(c.message), std::string::npos) << c.flag << ": " << run.err;
  }
  std::filesystem::remove_all(data);
}

}  // namespace
}  // namespace impostor::testing
