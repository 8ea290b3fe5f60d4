// A real impostor-server with --http-listen and a real worker: /metrics is
// scraped before and after a bake and a cache hit and every counter must
// have moved by exactly what happened; the JSON API lists what the gRPC
// side did; bad paths, parameters and flag values are refused.
#include <chrono>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "common/util/sha256.h"
#include "tests/support/server_process.h"
#include "tests/metrics/exposition_parser.h"
#include "tests/metrics/http_test_client.h"

namespace impostor {
namespace {

using testing::AssetsDir;
using testing::ContextWithin;
using testing::Exposition;
using testing::ParseExposition;
using testing::HttpPort;
using testing::ServerProcess;

// The test client plus /metrics parsed and JSON answers checked.
struct Http : testing::HttpTestClient {
  using HttpTestClient::HttpTestClient;
  Exposition Scrape() {
    auto res = Get("/metrics");
    EXPECT_TRUE(res && res->status == 200);
    if (!res) return {};
    EXPECT_NE(res->get_header_value("Content-Type").find("text/plain; version=0.0.4"), std::string::npos);
    auto parsed = ParseExposition(res->body);
    EXPECT_TRUE(parsed.ok()) << parsed.status() << "\n" << res->body;
    return parsed.ok() ? *parsed : Exposition();
  }
  nlohmann::json Json(const std::string& path, int expect_status = 200) {
    auto res = Get(path);
    EXPECT_TRUE(res) << path;
    if (!res) return {};
    EXPECT_EQ(res->status, expect_status) << path << ": " << res->body;
    EXPECT_EQ(res->get_header_value("Content-Type"), "application/json") << path;
    return nlohmann::json::parse(res->body, nullptr, false);
  }
};

v1::SubmitBakeRequest BoxRequest(ServerProcess& server) {
  v1::SubmitBakeRequest request;
  *request.mutable_mesh() =
      testing::UploadGlb(server.assets(), AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb");
  request.mutable_parameters()->set_frames(4);
  request.mutable_parameters()->set_resolution(128);
  request.mutable_parameters()->set_quality_views(0);
  return request;
}

v1::SubmitBakeResponse Submit(ServerProcess& server, const v1::SubmitBakeRequest& request) {
  v1::SubmitBakeResponse response;
  const grpc::Status s = server.bake().SubmitBake(ContextWithin().get(), request, &response);
  EXPECT_TRUE(s.ok()) << s.error_message();
  return response;
}

TEST(HttpMetrics, CountersMoveByExactlyOneBakeAndOneCacheHit) {
  ServerProcess server(/*local_workers=*/1, {"--http-listen=127.0.0.1:0"});
  Http http(HttpPort(server));
  const v1::SubmitBakeRequest request = BoxRequest(server);
  const Exposition before = http.Scrape();

  const v1::SubmitBakeResponse first = Submit(server, request);
  const v1::Job done = testing::WatchToEnd(server.bake(), first.job_id());
  ASSERT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();

  auto delta = [&](const Exposition& a, const Exposition& b, const std::string& name,
                   const std::map<std::string, std::string>& labels = {}) {
    return b.Value(name, labels) - a.Value(name, labels);
  };
  // The watch sees SUCCEEDED as soon as the result is committed, which can
  // be before the worker's CompleteJob call has returned and been counted:
  // scrape until it has (bounded).
  const std::map<std::string, std::string> complete_ok = {{"method", "/impostor.v1.WorkerService/CompleteJob"},
                                                           {"code", "OK"}};
  Exposition baked = http.Scrape();
  for (const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
       delta(before, baked, "impostor_rpcs_total", complete_ok) < 1 && std::chrono::steady_clock::now() < give_up;) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    baked = http.Scrape();
  }
  const std::map<std::string, std::string> atlas = {{"product", "atlas"}};
  EXPECT_EQ(delta(before, baked, "impostor_submits_total", {{"product", "atlas"}, {"outcome", "queued"}}), 1);
  EXPECT_EQ(delta(before, baked, "impostor_cache_misses_total", atlas), 1);
  EXPECT_EQ(delta(before, baked, "impostor_cache_hits_total", atlas), 0);
  EXPECT_EQ(delta(before, baked, "impostor_leases_total", atlas), 1);
  EXPECT_EQ(delta(before, baked, "impostor_jobs_completed_total", atlas), 1);
  EXPECT_EQ(delta(before, baked, "impostor_bake_seconds_count", atlas), 1);
  EXPECT_EQ(delta(before, baked, "impostor_lease_latency_seconds_count", atlas), 1);
  EXPECT_EQ(delta(before, baked, "impostor_bake_stage_seconds_count", {{"product", "atlas"}, {"stage", "render"}}), 1);
  EXPECT_EQ(baked.Sum("impostor_worker_jobs_completed_total") - before.Sum("impostor_worker_jobs_completed_total"), 1);
  EXPECT_EQ(delta(before, baked, "impostor_jobs", {{"state", "succeeded"}}), 1);
  EXPECT_EQ(baked.Value("impostor_jobs", {{"state", "running"}}), 0);
  EXPECT_EQ(delta(before, baked, "impostor_rpcs_total",
                  {{"method", "/impostor.v1.BakeService/SubmitBake"}, {"code", "OK"}}), 1);
  EXPECT_EQ(delta(before, baked, "impostor_rpcs_total", complete_ok), 1);
  EXPECT_GT(baked.Value("impostor_blob_store_bytes"), before.Value("impostor_blob_store_bytes"));
  EXPECT_EQ(baked.Sum("impostor_workers"), 1);
  EXPECT_EQ(baked.Value("impostor_ready"), 1);

  const v1::SubmitBakeResponse second = Submit(server, request);
  EXPECT_TRUE(second.cached());
  const Exposition hit = http.Scrape();
  EXPECT_EQ(delta(baked, hit, "impostor_submits_total", {{"product", "atlas"}, {"outcome", "cache_hit"}}), 1);
  EXPECT_EQ(delta(baked, hit, "impostor_submits_total", {{"product", "atlas"}, {"outcome", "queued"}}), 0);
  EXPECT_EQ(delta(baked, hit, "impostor_cache_hits_total", atlas), 1);
  EXPECT_EQ(delta(baked, hit, "impostor_cache_misses_total", atlas), 0);
  EXPECT_EQ(delta(baked, hit, "impostor_jobs_completed_total", atlas), 0);
  EXPECT_EQ(delta(baked, hit, "impostor_bake_seconds_count", atlas), 0);
  EXPECT_EQ(delta(baked, hit, "impostor_leases_total", atlas), 0);
  // A cache hit writes no job row (issue 18): the jobs gauge stays.
  EXPECT_EQ(delta(baked, hit, "impostor_jobs", {{"state", "succeeded"}}), 0);

  // The JSON API shows the same farm: the bake's job in the list, and the
  // hit's job by its id.
  const nlohmann::json jobs = http.Json("/api/v1/jobs?state=succeeded&page_size=10");
  ASSERT_EQ(jobs["jobs"].size(), 1u) << jobs.dump();
  EXPECT_EQ(jobs["jobs"][0]["job_id"], first.job_id());
  EXPECT_FALSE(jobs.contains("next_page_token"));
  const nlohmann::json hit_job = http.Json("/api/v1/jobs/" + second.job_id());
  EXPECT_EQ(hit_job["state"], "succeeded") << hit_job.dump();
  EXPECT_EQ(hit_job["cached"], true) << hit_job.dump();
  EXPECT_EQ(http.Json("/api/v1/jobs?state=running")["jobs"].size(), 0u);

  const nlohmann::json job = http.Json("/api/v1/jobs/" + first.job_id());
  EXPECT_EQ(job["state"], "succeeded");
  EXPECT_EQ(job["result"]["cache_key"], first.cache_key());
  EXPECT_EQ(job["parameters"]["frames"], 4);
  EXPECT_FALSE(job["worker_id"].get<std::string>().empty());

  const nlohmann::json workers = http.Json("/api/v1/workers");
  ASSERT_EQ(workers["workers"].size(), 1u) << workers.dump();
  EXPECT_EQ(workers["workers"][0]["worker_id"], job["worker_id"]);
  EXPECT_EQ(workers["workers"][0]["jobs_completed"], 1);

  const nlohmann::json summary = http.Json("/api/v1/summary");
  EXPECT_EQ(summary["jobs"]["succeeded"], 1);  // job rows: the hit has none
  EXPECT_EQ(summary["cache_hits"], 1);
  EXPECT_EQ(summary["cache_misses"], 1);
  EXPECT_DOUBLE_EQ(summary["cache_hit_ratio"].get<double>(), 0.5);

  const nlohmann::json results = http.Json("/api/v1/results");
  ASSERT_EQ(results["results"].size(), 1u);
  EXPECT_EQ(results["results"][0]["cache_key"], first.cache_key());
  const nlohmann::json result = http.Json("/api/v1/results/" + first.cache_key());
  EXPECT_EQ(result["manifest"]["frames"], 4);
  for (const auto& map : done.result().maps()) {
    auto file = http.Get("/api/v1/results/" + first.cache_key() + "/files/" + map.file());
    ASSERT_TRUE(file && file->status == 200) << map.file();
    EXPECT_EQ(Sha256Hex(file->body), map.digest().hash()) << map.file();
    EXPECT_EQ(file->get_header_value("Content-Type"), "image/png") << map.file();
  }
  auto manifest = http.Get("/api/v1/results/" + first.cache_key() + "/files/manifest.json");
  ASSERT_TRUE(manifest && manifest->status == 200);
  EXPECT_EQ(Sha256Hex(manifest->body), done.result().manifest_json().hash());
  auto mesh = http.Get("/api/v1/jobs/" + first.job_id() + "/mesh/" + request.mesh().entry().path());
  ASSERT_TRUE(mesh && mesh->status == 200);
  EXPECT_EQ(Sha256Hex(mesh->body), request.mesh().entry().digest().hash());
}

// Pools and shares (issue 44): /api/v1/pools and the impostor_pool_*
// gauges show a pool's workers, its running jobs and a share's team, from a
// worker tagged gpu that leased team-forest's bake (a LeaseJob by hand, so
// the job stays running while the test looks).
TEST(HttpMetrics, PoolsShowTheirWorkersRunningJobsAndShares) {
  ServerProcess server(/*local_workers=*/0,
                       {"--http-listen=127.0.0.1:0", "--pools=gpu", "--pool-shares=gpu:team-forest=50"});
  Http http(HttpPort(server));
  auto lease = [&] {
    v1::LeaseJobRequest request;
    request.set_worker_id("gpu-a");
    request.set_wait_seconds(0);
    v1::WorkerCapabilities* caps = request.mutable_capabilities();
    caps->set_device_kind("discrete");
    caps->set_baker_version("test");
    caps->add_tags("gpu");
    v1::LeaseJobResponse response;
    const grpc::Status s = server.workers().LeaseJob(ContextWithin().get(), request, &response);
    EXPECT_TRUE(s.ok()) << s.error_message();
    return response;
  };
  auto submitter = ContextWithin();
  submitter->AddMetadata("impostor-client-id", "team-forest");
  v1::SubmitBakeResponse submitted;
  ASSERT_TRUE(server.bake().SubmitBake(submitter.get(), BoxRequest(server), &submitted).ok());
  ASSERT_TRUE(lease().has_job());

  const nlohmann::json pools = http.Json("/api/v1/pools");
  ASSERT_EQ(pools["pools"].size(), 1u) << pools.dump();
  const nlohmann::json& gpu = pools["pools"][0];
  EXPECT_EQ(gpu["name"], "gpu") << gpu.dump();
  EXPECT_EQ(gpu["tag"], "gpu") << gpu.dump();
  EXPECT_EQ(gpu["workers"], 1) << gpu.dump();
  EXPECT_EQ(gpu["running"], 1) << gpu.dump();
  ASSERT_EQ(gpu["shares"].size(), 1u) << gpu.dump();
  EXPECT_EQ(gpu["shares"][0]["team"], "team-forest");
  EXPECT_EQ(gpu["shares"][0]["percent"], 50);
  EXPECT_EQ(gpu["shares"][0]["guaranteed_workers"], 1);
  EXPECT_EQ(gpu["shares"][0]["running"], 1);

  const Exposition m = http.Scrape();
  EXPECT_EQ(m.Value("impostor_pool_workers", {{"pool", "gpu"}}), 1);
  EXPECT_EQ(m.Value("impostor_pool_running_jobs", {{"pool", "gpu"}}), 1);
  EXPECT_EQ(m.Value("impostor_pool_share_running_jobs", {{"pool", "gpu"}, {"team", "team-forest"}}), 1);
  EXPECT_EQ(m.Value("impostor_pool_share_guaranteed_workers", {{"pool", "gpu"}, {"team", "team-forest"}}), 1);
  EXPECT_EQ(m.types.at("impostor_pool_workers"), "gauge");
}

TEST(HttpMetrics, BadPathsAndParametersAreRefusedNamingWhatIsWrong) {
  ServerProcess server(/*local_workers=*/0, {"--http-listen=127.0.0.1:0"});
  Http http(HttpPort(server));
  auto health = http.Get("/healthz");
  ASSERT_TRUE(health);
  EXPECT_EQ(health->status, 200);
  auto ready = http.Get("/readyz");
  ASSERT_TRUE(ready);
  EXPECT_EQ(ready->status, 200);
  EXPECT_EQ(ready->body, "ready\n");

  struct Case {
    const char* path;
    int status;
    const char* expect;  // in error.message
  };
  const Case cases[] = {
      {"/no/such/page", 404, "no such path: /no/such/page"},
      {"/api/v1/nothing", 404, "no such path"},
      {"/api/v1/jobs/job-unknown", 404, "job_id: no job"},
      {"/api/v1/jobs?page_size=abc", 400, "page_size: \"abc\" is not a whole number in 1..500"},
      {"/api/v1/jobs?page_size=501", 400, "page_size"},
      {"/api/v1/jobs?state=finished", 400, "state: \"finished\" is not one of"},
      {"/api/v1/jobs?page_token=garbage", 400, "page_token"},
      {"/api/v1/jobs?sort=asc", 400, "\"sort\": unknown query parameter"},
      {"/api/v1/jobs?state=queued&state=failed", 400, "state: given more than once"},
      {"/api/v1/workers?x=1", 400, "this path takes none"},
      {"/api/v1/results/not-a-key", 400, "cache_key: expected 64 lowercase hex"},
      {"/api/v1/results/0000000000000000000000000000000000000000000000000000000000000000", 404,
       "cache_key: nothing baked"},
      {"/api/v1/results/0000000000000000000000000000000000000000000000000000000000000000/files/x.png", 404,
       "nothing baked"},
      {"/api/v1/results?page_token=1.zz", 400, "page_token"},
      // Bytes that are not UTF-8 (echoed as U+FFFD, not an empty 500).
      {"/api/v1/jobs?page_token=%ff", 400, "page_token"},
      {"/api/v1/jobs?state=%ff", 400, "state: \"\xEF\xBF\xBD\" is not one of"},
      {"/api/v1/jobs?%ff=1", 400, "unknown query parameter"},
      {"/api/v1/jobs/%ff", 404, "job_id: no job"},
      {"/api/v1/results/%ff", 400, "cache_key"},
  };
  for (const Case& c : cases) {
    const nlohmann::json body = http.Json(c.path, c.status);
    ASSERT_TRUE(body.is_object()) << c.path;
    EXPECT_EQ(body["error"]["code"], c.status) << c.path;
    EXPECT_NE(body["error"]["message"].get<std::string>().find(c.expect), std::string::npos)
        << c.path << ": " << body.dump();
  }
}

TEST(HttpMetrics, BadHttpListenValuesAreRefusedAtStart) {
  // A port another listener holds.
  httplib::Server holder;
  const int taken = holder.bind_to_any_port("127.0.0.1");
  ASSERT_GT(taken, 0);
  struct Case {
    std::string value;
    std::string expect;
  };
  const Case cases[] = {
      {"8080", "--http-listen: \"8080\" has no port"},
      {"127.0.0.1:70000", "--http-listen: \"127.0.0.1:70000\" has a port that is not a number in 0..65535"},
      {":80", "has no host"},
      {"127.0.0.1:" + std::to_string(taken), "--http-listen: cannot listen on 127.0.0.1:" + std::to_string(taken)},
  };
  for (const Case& c : cases) {
    const auto dir = testing::NewTempDir("http_listen_flag");
    const testing::ToolRun run = testing::RunTool({(testing::BinaryDir() / "impostor-server").string(),
                                                   "--listen=127.0.0.1:0", "--data=" + dir.string(),
                                                   "--http-listen=" + c.value},
                                                  std::chrono::seconds(60));
    EXPECT_EQ(run.exit_code, 2) << c.value << "\n" << run.err;
    EXPECT_NE(run.err.find(c.expect), std::string::npos) << c.value << "\n" << run.err;
    EXPECT_EQ(run.out.find("listening on"), std::string::npos) << c.value << ": started anyway";
  }
  // A dashboard directory that is not there, named by the admin: a typo.
  const auto dir = testing::NewTempDir("http_static_flag");
  const testing::ToolRun run = testing::RunTool({(testing::BinaryDir() / "impostor-server").string(),
                                                 "--listen=127.0.0.1:0", "--data=" + dir.string(),
                                                 "--http-listen=127.0.0.1:0", "--http-static-dir=/nonexistent/web"},
                                                std::chrono::seconds(60));
  EXPECT_EQ(run.exit_code, 2) << run.err;
  EXPECT_NE(run.err.find("--http-static-dir: /nonexistent/web is not a directory"), std::string::npos) << run.err;
}

}  // namespace
}  // namespace impostor
