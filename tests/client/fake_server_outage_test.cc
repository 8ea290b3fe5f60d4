// The SDK's watch and retries against the fake impostor.v1 services
// (fake_server.h): a watch resumes after broken streams, an outage is ridden
// out within its budget, retried submits keep their request ids, and
// uploads and downloads pick up where an outage left them.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <functional>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "client/transport/transport.h"
#include "tests/client/fake_server.h"

namespace impostor::sdk {
namespace {

TEST_F(FakeServerTest, WatchResumesAfterBrokenStream) {
  {
    std::lock_guard lock(fake_.mu);
    fake_.watch_scripts = {
        {MakeJob(v1::JOB_STATE_QUEUED, 0, ""), MakeJob(v1::JOB_STATE_RUNNING, 0.1f, "render")},
        {MakeJob(v1::JOB_STATE_RUNNING, 0.5f, "render"), MakeJob(v1::JOB_STATE_SUCCEEDED, 1, "")},
    };
    fake_.get_job = MakeJob(v1::JOB_STATE_RUNNING, 0.5f, "render");
  }
  std::vector<JobUpdate> seen;
  absl::StatusOr<JobUpdate> done = client_->WatchJob("job-1", [&](const JobUpdate& u) { seen.push_back(u); });
  ASSERT_TRUE(done.ok()) << done.status();
  EXPECT_EQ(done->state, JobState::kSucceeded);
  // queued, running 10%, running 50% (from GetJob; the new stream's repeat is
  // dropped), succeeded.
  ASSERT_EQ(seen.size(), 4u);
  EXPECT_EQ(seen[0].state, JobState::kQueued);
  EXPECT_EQ(seen[2].progress, 0.5);
  EXPECT_EQ(seen[3].state, JobState::kSucceeded);
}

TEST_F(FakeServerTest, WatchReportsFailedBakeAsState) {
  v1::Job failed = MakeJob(v1::JOB_STATE_FAILED, 0.2f, "load");
  failed.mutable_error()->set_code(3);
  failed.mutable_error()->set_message("mesh: no triangles");
  {
    std::lock_guard lock(fake_.mu);
    fake_.watch_scripts = {{failed}};
  }
  absl::StatusOr<JobUpdate> done = client_->WatchJob("job-1", nullptr);
  ASSERT_TRUE(done.ok()) << done.status();
  EXPECT_EQ(done->state, JobState::kFailed);
  EXPECT_EQ(done->error_code, 3);
  EXPECT_EQ(done->error_message, "mesh: no triangles");
}

TEST_F(FakeServerTest, WatchUnknownJobIsNotFound) {
  absl::StatusOr<JobUpdate> done = client_->WatchJob("nope", nullptr);
  EXPECT_EQ(done.status().code(), absl::StatusCode::kNotFound) << done.status();
}

// Records ClientOptions::on_connection_change events.
struct EventLog {
  std::mutex mu;
  std::vector<ConnectionEvent> events;
  std::function<void(const ConnectionEvent&)> Callback() {
    return [this](const ConnectionEvent& e) {
      std::lock_guard lock(mu);
      events.push_back(e);
    };
  }
  int Count(ConnectionEvent::Kind kind) {
    std::lock_guard lock(mu);
    return static_cast<int>(std::count_if(events.begin(), events.end(), [&](const auto& e) { return e.kind == kind; }));
  }
};

// The outage outlasts max_attempts (2) on every step of a watch: the broken
// stream, the GetJob that follows and the next stream. The old SDK returned
// the first failed GetJob here.
// A retry's backoff during an outage waits on the channel, which is what
// drives a sync channel's reconnection: a server back on its port is found
// as soon as it listens, not at the next backup poll (every 5 s), which a
// 500-asset batch waited out 2-5 s after every restart.
TEST_F(FakeServerTest, WaitForServerReturnsOnceARestartedServerListens) {
  ClientOptions options;
  options.server = "127.0.0.1:" + std::to_string(port_);
  auto transport = Transport::Connect(options);
  ASSERT_TRUE(transport.ok()) << transport.status();
  server_->Shutdown();
  server_.reset();
  // Down: the whole wait (the channel cannot connect).
  const auto down_start = std::chrono::steady_clock::now();
  (*transport)->WaitForServer(std::chrono::milliseconds(300));
  EXPECT_GE(std::chrono::steady_clock::now() - down_start, std::chrono::milliseconds(300));

  constexpr auto kLongWait = std::chrono::seconds(60);
  std::atomic<bool> waited{false};
  std::chrono::steady_clock::duration waited_for{};
  std::thread waiter([&] {
    const auto start = std::chrono::steady_clock::now();
    (*transport)->WaitForServer(kLongWait);
    waited_for = std::chrono::steady_clock::now() - start;
    waited = true;
  });
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort("127.0.0.1:" + std::to_string(port_), grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(static_cast<v1::AssetService::Service*>(&fake_));
  builder.RegisterService(static_cast<v1::BakeService::Service*>(&fake_));
  server_ = builder.BuildAndStart();
  ASSERT_NE(server_, nullptr);
  ASSERT_EQ(port, port_);
  waiter.join();
  EXPECT_TRUE(waited.load());
  EXPECT_LT(waited_for, kLongWait) << "returned once connected, not at the end of its wait";
  // Connected: a call goes through at once.
  absl::StatusOr<v1::Job> job = (*transport)->GetJob("job-1");
  EXPECT_NE(job.status().code(), absl::StatusCode::kUnavailable) << job.status();

  // Up and connected: a server that answers UNAVAILABLE is not hammered,
  // the backoff is waited in full.
  const auto up_start = std::chrono::steady_clock::now();
  (*transport)->WaitForServer(std::chrono::milliseconds(200));
  EXPECT_GE(std::chrono::steady_clock::now() - up_start, std::chrono::milliseconds(200));
}

TEST_F(FakeServerTest, WatchRidesOutAnOutageLongerThanItsAttempts) {
  {
    std::lock_guard lock(fake_.mu);
    fake_.watch_scripts = {
        {MakeJob(v1::JOB_STATE_QUEUED, 0, ""), MakeJob(v1::JOB_STATE_RUNNING, 0.1f, "render")},
        {MakeJob(v1::JOB_STATE_RUNNING, 0.5f, "render"), MakeJob(v1::JOB_STATE_SUCCEEDED, 1, "")},
    };
    fake_.get_job = MakeJob(v1::JOB_STATE_RUNNING, 0.5f, "render");
    fake_.get_job_unavailable = 4;
  }
  EventLog log;
  auto client = Connect(2, 60, log.Callback());
  ASSERT_NE(client, nullptr);
  std::vector<JobUpdate> seen;
  absl::StatusOr<JobUpdate> done = client->WatchJob("job-1", [&](const JobUpdate& u) { seen.push_back(u); });
  ASSERT_TRUE(done.ok()) << done.status();
  EXPECT_EQ(done->state, JobState::kSucceeded);
  ASSERT_FALSE(seen.empty());
  EXPECT_EQ(seen.back().state, JobState::kSucceeded);
  {
    std::lock_guard lock(fake_.mu);
    EXPECT_EQ(fake_.get_job_calls, 5) << "four refused, then answered";
    EXPECT_EQ(fake_.watch_calls, 2);
  }
  // One outage, reported once each way however many calls saw it.
  EXPECT_EQ(log.Count(ConnectionEvent::Kind::kLost), 1);
  EXPECT_EQ(log.Count(ConnectionEvent::Kind::kRegained), 1);
  std::lock_guard lock(log.mu);
  ASSERT_EQ(log.events.size(), 2u);
  EXPECT_EQ(log.events[0].kind, ConnectionEvent::Kind::kLost);
  EXPECT_EQ(log.events[0].error.code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(log.events[0].server, "127.0.0.1:" + std::to_string(port_));
  EXPECT_EQ(log.events[0].max_outage_seconds, 60);
  EXPECT_EQ(log.events[1].kind, ConnectionEvent::Kind::kRegained);
  EXPECT_GT(log.events[1].outage_seconds, 0);
}

TEST_F(FakeServerTest, WatchResumesWhenNewStreamsAreRefusedToo) {
  {
    std::lock_guard lock(fake_.mu);
    // The first stream breaks; the next three end at once with UNAVAILABLE
    // (empty scripts), more than max_attempts in a row without news.
    fake_.watch_scripts = {{MakeJob(v1::JOB_STATE_RUNNING, 0.1f, "render")}, {}, {}, {},
                           {MakeJob(v1::JOB_STATE_SUCCEEDED, 1, "")}};
    fake_.get_job = MakeJob(v1::JOB_STATE_RUNNING, 0.1f, "render");
  }
  auto client = Connect(2, 60);
  ASSERT_NE(client, nullptr);
  absl::StatusOr<JobUpdate> done = client->WatchJob("job-1", nullptr);
  ASSERT_TRUE(done.ok()) << done.status();
  EXPECT_EQ(done->state, JobState::kSucceeded);
  std::lock_guard lock(fake_.mu);
  EXPECT_EQ(fake_.watch_calls, 5);
}

// Streams that end without news while the server answers are no outage:
// max_attempts of them in a row end the watch, as an RPC error.
TEST_F(FakeServerTest, WatchGivesUpOnStreamsThatEndWithoutNews) {
  {
    std::lock_guard lock(fake_.mu);
    fake_.watch_scripts = {{MakeJob(v1::JOB_STATE_RUNNING, 0.1f, "render")}, {}, {}, {}};
    fake_.watch_ends_ok = true;
    fake_.get_job = MakeJob(v1::JOB_STATE_RUNNING, 0.1f, "render");
  }
  auto client = Connect(2, 60);
  ASSERT_NE(client, nullptr);
  absl::StatusOr<JobUpdate> done = client->WatchJob("job-1", nullptr);
  ASSERT_EQ(done.status().code(), absl::StatusCode::kUnavailable) << done.status();
  std::optional<RpcErrorInfo> info = GetRpcErrorInfo(done.status());
  ASSERT_TRUE(info.has_value()) << done.status();
  EXPECT_EQ(info->rpc, "WatchJob");
  EXPECT_NE(info->server_message.find("ended before the job finished"), std::string::npos) << done.status();
  std::lock_guard lock(fake_.mu);
  EXPECT_EQ(fake_.watch_calls, 2) << "the stream with news and its end count as one failure, the empty one as the second";
}

TEST_F(FakeServerTest, OutageBudgetSpentReturnsTheLastUnavailable) {
  {
    std::lock_guard lock(fake_.mu);
    fake_.get_job_unavailable = 1 << 30;  // never back
  }
  EventLog log;
  auto client = Connect(1, 2, log.Callback());
  ASSERT_NE(client, nullptr);
  absl::StatusOr<JobUpdate> job = client->GetJob("job-1");
  ASSERT_EQ(job.status().code(), absl::StatusCode::kUnavailable) << job.status();
  EXPECT_NE(job.status().message().find("GetJob"), std::string::npos) << job.status();
  EXPECT_NE(job.status().message().find("server down (test)"), std::string::npos) << job.status();
  {
    std::lock_guard lock(fake_.mu);
    EXPECT_GT(fake_.get_job_calls, 1) << "max_attempts is 1: only the outage budget retries";
  }
  EXPECT_EQ(log.Count(ConnectionEvent::Kind::kLost), 1);
  EXPECT_EQ(log.Count(ConnectionEvent::Kind::kRegained), 0);
}

TEST_F(FakeServerTest, ZeroOutageBudgetTriesMaxAttemptsOnly) {
  {
    std::lock_guard lock(fake_.mu);
    fake_.get_job_unavailable = 1 << 30;
  }
  auto client = Connect(3, 0);
  ASSERT_NE(client, nullptr);
  EXPECT_EQ(client->GetJob("job-1").status().code(), absl::StatusCode::kUnavailable);
  std::lock_guard lock(fake_.mu);
  EXPECT_EQ(fake_.get_job_calls, 3);
}

TEST_F(FakeServerTest, ErrorsOtherThanUnavailableAreNotRetried) {
  const std::vector<grpc::StatusCode> codes = {
      grpc::StatusCode::NOT_FOUND,         grpc::StatusCode::INVALID_ARGUMENT,   grpc::StatusCode::FAILED_PRECONDITION,
      grpc::StatusCode::PERMISSION_DENIED, grpc::StatusCode::RESOURCE_EXHAUSTED, grpc::StatusCode::INTERNAL,
      grpc::StatusCode::DATA_LOSS,         grpc::StatusCode::UNAUTHENTICATED};
  auto client = Connect(5, 60);
  ASSERT_NE(client, nullptr);
  for (grpc::StatusCode code : codes) {
    {
      std::lock_guard lock(fake_.mu);
      fake_.get_job_code = code;
      fake_.get_job_calls = 0;
    }
    absl::StatusOr<JobUpdate> job = client->GetJob("job-1");
    EXPECT_EQ(static_cast<int>(job.status().code()), static_cast<int>(code)) << "code " << code;
    std::lock_guard lock(fake_.mu);
    EXPECT_EQ(fake_.get_job_calls, 1) << "code " << code << " was retried";
  }
}

TEST_F(FakeServerTest, RetriedSubmitSendsTheSameRequestId) {
  const fs::path model = kAssets / "props_pbr/Box/glTF-Binary/Box.glb";
  {
    std::lock_guard lock(fake_.mu);
    fake_.submit_unavailable = 3;
  }
  auto client = Connect(2, 60);
  ASSERT_NE(client, nullptr);
  absl::StatusOr<SubmitResult> r = client->SubmitBake(model, {});
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_TRUE(client->SubmitBake(model, {}).ok());
  std::lock_guard lock(fake_.mu);
  ASSERT_EQ(fake_.submits.size(), 5u) << "three refused, one accepted, then a second submit";
  const std::string id = fake_.submits[0].request_id();
  EXPECT_EQ(id.size(), 32u) << id;
  EXPECT_EQ(id.find_first_not_of("0123456789abcdef"), std::string::npos) << id;
  for (size_t i = 1; i < 4; ++i) EXPECT_EQ(fake_.submits[i].request_id(), id) << "retry " << i;
  EXPECT_NE(fake_.submits[4].request_id(), id) << "a new logical submit gets a new id";
  EXPECT_EQ(fake_.submits[4].request_id().size(), 32u);
}

TEST_F(FakeServerTest, BatchItemsGetDistinctRequestIdsKeptOnRetry) {
  const fs::path box = kAssets / "props_pbr/Box/glTF-Binary/Box.glb";
  {
    std::lock_guard lock(fake_.mu);
    fake_.submit_unavailable = 1;  // the first item's first try
  }
  auto client = Connect(1, 60);
  ASSERT_NE(client, nullptr);
  absl::StatusOr<std::vector<BatchSubmission>> r = client->SubmitBakeBatch({{box, {}}, {box, {}}, {box, {}}}, nullptr);
  ASSERT_TRUE(r.ok()) << r.status();
  for (const BatchSubmission& b : *r) EXPECT_TRUE(b.status.ok()) << b.status;
  std::lock_guard lock(fake_.mu);
  ASSERT_EQ(fake_.submits.size(), 4u);
  EXPECT_EQ(fake_.submits[0].request_id(), fake_.submits[1].request_id()) << "the retry of item 0";
  std::set<std::string> ids;
  for (const auto& submit : fake_.submits) ids.insert(submit.request_id());
  EXPECT_EQ(ids.size(), 3u) << "one id per item";
}

TEST_F(FakeServerTest, UploadStartsOverThroughAnOutage) {
  const fs::path model = kAssets / "props_pbr/Box/glTF-Binary/Box.glb";
  {
    std::lock_guard lock(fake_.mu);
    fake_.upload_unavailable = 4;
  }
  auto client = Connect(2, 60);
  ASSERT_NE(client, nullptr);
  absl::StatusOr<SubmitResult> r = client->SubmitBake(model, {});
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->upload.uploaded, 1);
  std::lock_guard lock(fake_.mu);
  EXPECT_EQ(fake_.upload_calls, 5);
  ASSERT_EQ(fake_.uploaded.size(), 1u);
  EXPECT_EQ(fake_.blobs.at(fake_.uploaded[0]), ReadAll(model)) << "the stored blob is the whole file";
}

TEST_F(FakeServerTest, DownloadResumesAtItsOffsetAfterAnOutage) {
  const std::string key = AddResult();
  {
    std::lock_guard lock(fake_.mu);
    // The albedo map's stream breaks after two 1000-byte chunks; then the
    // server refuses four ReadBlobs, twice max_attempts.
    fake_.break_once.insert(Sha256Hex(contents_["albedo_alpha.png"]));
    fake_.refuse_after_break = 4;
  }
  auto client = Connect(2, 60);
  ASSERT_NE(client, nullptr);
  absl::StatusOr<FetchResult> r = client->Fetch(key, dir_);
  ASSERT_TRUE(r.ok()) << r.status();
  for (const auto& [name, bytes] : contents_) EXPECT_EQ(ReadAll(dir_ / name), bytes) << name;
  std::lock_guard lock(fake_.mu);
  // The albedo map's requests: from 0, then from 2000 on every retry.
  // (Refusals may land on the other map's stream too, so the albedo map
  // gets at least one retry from 2000 and never one from elsewhere.)
  const std::vector<int64_t>& albedo = fake_.read_offsets_by_hash[Sha256Hex(contents_["albedo_alpha.png"])];
  ASSERT_GE(albedo.size(), 2u);
  EXPECT_EQ(albedo.front(), 0);
  EXPECT_EQ(albedo.back(), 2000) << "the last, successful request resumed at 2000";
  for (size_t i = 1; i < albedo.size(); ++i) EXPECT_EQ(albedo[i], 2000) << "request " << i;
}

}  // namespace
}  // namespace impostor::sdk
