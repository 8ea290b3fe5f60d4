// Several head-node replicas behind one client (issue 15): the server list
// parser (common/net/server_list.h), and the SDK's failover between in-process
// fake replicas: a dead first address, a replica shut down under a
// connected client, an UNAVAILABLE answer, a watch broken midway; and
// malformed lists refused by every front door (SDK, cache, C API, CLI).
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "client/cli/cli_args.h"
#include "common/net/server_list.h"
#include "impostor/cache.h"
#include "impostor/client.h"
#include "impostor/impostor_c.h"
#include "impostor/v1/bake_service.grpc.pb.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------
// ParseServerList

TEST(ParseServerList, AcceptsListsOfTargets) {
  struct Case {
    const char* list;
    std::vector<std::string> targets;
  };
  for (const Case& c : std::vector<Case>{
           {"localhost:50051", {"localhost:50051"}},
           {"bake1:50051,bake2:50051", {"bake1:50051", "bake2:50051"}},
           {" bake1:1 , 10.0.0.2:65535 ", {"bake1:1", "10.0.0.2:65535"}},
           {"[::1]:50051,127.0.0.1:50051", {"[::1]:50051", "127.0.0.1:50051"}},
           {"dns:///farm.studio.lan:50051", {"dns:///farm.studio.lan:50051"}},
           {"dns://10.0.0.53:53/farm.lan:7000,unix:/run/impostor.sock",
            {"dns://10.0.0.53:53/farm.lan:7000", "unix:/run/impostor.sock"}},
           // gRPC's own comma list stays one target (one channel, pick_first).
           {"ipv4:10.0.0.1:50051,10.0.0.2:50051", {"ipv4:10.0.0.1:50051,10.0.0.2:50051"}},
       }) {
    absl::StatusOr<std::vector<std::string>> targets = ParseServerList(c.list, "--server");
    ASSERT_TRUE(targets.ok()) << c.list << ": " << targets.status();
    EXPECT_EQ(*targets, c.targets) << c.list;
  }
}

TEST(ParseServerList, RefusesMalformedListsNamingTheFieldAndEntry) {
  struct Case {
    const char* list;
    const char* says;  // a piece of the message
  };
  for (const Case& c : std::vector<Case>{
           {"", "required"},
           {"  ", "required"},
           {"a:1,,b:2", "address 2 of \"a:1,,b:2\" is empty"},
           {"a:1,", "address 2"},
           {"bake.lan", "\"bake.lan\" has no port"},
           {"bake.lan:0", "no valid port"},
           {"bake.lan:65536", "no valid port"},
           {"bake.lan:http", "no valid port"},
           {"bake lan:1", "white space"},
           {"::1:50051", "IPv6 literals go in brackets"},
           {"[::1]", "no port after the [IPv6] host"},
           {"[zz]:1", "IPv6"},
           {":50051", "no host"},
           {"a:1,a:1", "\"a:1\" is listed twice"},
           {"http://bake:80", "unknown scheme \"http\""},
           {"a:1,ipv4:10.0.0.1:2", "mixes gRPC's ipv4:/ipv6: list"},
           {"dns://only-authority", "no name after the DNS authority"},
           {"unix:", "no socket path"},
           {"a:1,a:2,a:3,a:4,a:5,a:6,a:7,a:8,a:9,a:10,a:11,a:12,a:13,a:14,a:15,a:16,a:17", "more than 16"},
       }) {
    absl::StatusOr<std::vector<std::string>> targets = ParseServerList(c.list, "--server");
    ASSERT_FALSE(targets.ok()) << "accepted \"" << c.list << "\"";
    EXPECT_EQ(targets.status().code(), absl::StatusCode::kInvalidArgument) << c.list;
    const std::string message(targets.status().message());
    EXPECT_EQ(message.rfind("--server: ", 0), 0u) << c.list << ": " << message;
    EXPECT_NE(message.find(c.says), std::string::npos) << c.list << ": " << message;
  }
}

// ---------------------------------------------------------------------------
// Failover between fake replicas

// A port on 127.0.0.1 nothing listens on (bound by the kernel, then closed).
int UnusedPort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  EXPECT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)), 0);
  socklen_t len = sizeof(addr);
  EXPECT_EQ(::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len), 0);
  ::close(fd);
  return ntohs(addr.sin_port);
}

v1::Job JobIn(v1::JobState state) {
  v1::Job job;
  job.set_job_id("job-1");
  job.set_state(state);
  job.set_cache_key(std::string(64, 'c'));
  return job;
}

// One replica: answers GetJob with `job` and WatchJob with `watch` (then
// UNAVAILABLE when `watch_breaks`, as a replica killed mid-stream would),
// counting the calls it served.
class FakeReplica final : public v1::BakeService::Service {
 public:
  FakeReplica() {
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port_);
    builder.RegisterService(this);
    server_ = builder.BuildAndStart();
  }
  ~FakeReplica() override { Stop(); }
  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
  // Closes the listener and every connection, as a killed replica would.
  void Stop() {
    if (server_ == nullptr) return;
    server_->Shutdown(std::chrono::system_clock::now());
    server_->Wait();
    server_.reset();
  }

  grpc::Status GetJob(grpc::ServerContext*, const v1::GetJobRequest*, v1::Job* response) override {
    std::lock_guard lock(mu);
    ++get_job_calls;
    if (get_job_unavailable > 0) {
      --get_job_unavailable;
      return {grpc::StatusCode::UNAVAILABLE, "replica draining (test)"};
    }
    *response = job;
    return grpc::Status::OK;
  }
  grpc::Status WatchJob(grpc::ServerContext*, const v1::WatchJobRequest*, grpc::ServerWriter<v1::Job>* writer) override {
    std::vector<v1::Job> script;
    bool breaks;
    {
      std::lock_guard lock(mu);
      ++watch_calls;
      script = watch;
      breaks = watch_breaks;
    }
    for (const v1::Job& j : script) writer->Write(j);
    if (breaks) return {grpc::StatusCode::UNAVAILABLE, "replica killed (test)"};
    return grpc::Status::OK;
  }

  std::mutex mu;
  v1::Job job = JobIn(v1::JOB_STATE_RUNNING);
  std::vector<v1::Job> watch;
  bool watch_breaks = false;
  int get_job_unavailable = 0;
  int get_job_calls = 0;
  int watch_calls = 0;

 private:
  int port_ = 0;
  std::unique_ptr<grpc::Server> server_;
};

int Calls(FakeReplica& r, int FakeReplica::*counter) {
  std::lock_guard lock(r.mu);
  return r.*counter;
}

// Options that leave no room for the retry policy: any success after a
// failure is the failover's doing.
sdk::ClientOptions NoRetries(const std::string& server, std::vector<sdk::ConnectionEvent>* events = nullptr) {
  sdk::ClientOptions options;
  options.server = server;
  options.max_attempts = 1;
  options.max_outage_seconds = 0;
  options.connect_timeout_seconds = 20;
  if (events != nullptr) {
    options.on_connection_change = [events](const sdk::ConnectionEvent& e) { events->push_back(e); };
  }
  return options;
}

TEST(Failover, ConnectSkipsARefusingFirstAddress) {
  FakeReplica b;
  b.job = JobIn(v1::JOB_STATE_SUCCEEDED);
  const std::string dead = "127.0.0.1:" + std::to_string(UnusedPort());
  auto client = sdk::Client::Connect(NoRetries(dead + "," + b.address()));
  ASSERT_TRUE(client.ok()) << client.status();
  absl::StatusOr<sdk::JobUpdate> job = (*client)->GetJob("job-1");
  ASSERT_TRUE(job.ok()) << job.status();
  EXPECT_EQ(job->state, sdk::JobState::kSucceeded);
  EXPECT_EQ(Calls(b, &FakeReplica::get_job_calls), 1);
}

TEST(Failover, ReplicaStoppedUnderAConnectedClientNextCallReachesTheOther) {
  FakeReplica a, b;
  std::vector<sdk::ConnectionEvent> events;
  auto client = sdk::Client::Connect(NoRetries(a.address() + "," + b.address(), &events));
  ASSERT_TRUE(client.ok()) << client.status();
  ASSERT_TRUE((*client)->GetJob("job-1").ok());
  EXPECT_EQ(Calls(a, &FakeReplica::get_job_calls), 1);
  a.Stop();
  // The connection to A is gone; with one attempt and no outage budget only
  // the move to B can answer this call.
  absl::StatusOr<sdk::JobUpdate> job = (*client)->GetJob("job-1");
  ASSERT_TRUE(job.ok()) << job.status();
  EXPECT_EQ(Calls(b, &FakeReplica::get_job_calls), 1);
  // Calls stay on B.
  ASSERT_TRUE((*client)->GetJob("job-1").ok());
  EXPECT_EQ(Calls(b, &FakeReplica::get_job_calls), 2);
  // A replica answered all along: no outage was reported.
  EXPECT_TRUE(events.empty()) << events.size() << " connection events";
}

TEST(Failover, UnavailableAnswerMovesCallsOnAndTheyStay) {
  FakeReplica a, b;
  a.get_job_unavailable = 1000;
  auto client = sdk::Client::Connect(NoRetries(a.address() + "," + b.address()));
  ASSERT_TRUE(client.ok()) << client.status();
  for (int i = 0; i < 3; ++i) ASSERT_TRUE((*client)->GetJob("job-1").ok()) << i;
  EXPECT_EQ(Calls(a, &FakeReplica::get_job_calls), 1);
  EXPECT_EQ(Calls(b, &FakeReplica::get_job_calls), 3);
}

TEST(Failover, EveryReplicaDownIsOneUnavailableWithTheOutageReported) {
  FakeReplica a, b;
  a.get_job_unavailable = b.get_job_unavailable = 1000;
  std::vector<sdk::ConnectionEvent> events;
  auto client = sdk::Client::Connect(NoRetries(a.address() + "," + b.address(), &events));
  ASSERT_TRUE(client.ok()) << client.status();
  absl::StatusOr<sdk::JobUpdate> job = (*client)->GetJob("job-1");
  ASSERT_FALSE(job.ok());
  EXPECT_EQ(job.status().code(), absl::StatusCode::kUnavailable) << job.status();
  // Each replica tried once; then the farm counts as lost.
  EXPECT_EQ(Calls(a, &FakeReplica::get_job_calls), 1);
  EXPECT_EQ(Calls(b, &FakeReplica::get_job_calls), 1);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, sdk::ConnectionEvent::Kind::kLost);
}

TEST(Failover, WatchBrokenByAKilledReplicaResumesOnTheOther) {
  FakeReplica a, b;
  a.watch = {JobIn(v1::JOB_STATE_QUEUED), JobIn(v1::JOB_STATE_RUNNING)};
  a.watch_breaks = true;
  b.job = JobIn(v1::JOB_STATE_RUNNING);
  b.watch = {JobIn(v1::JOB_STATE_RUNNING), JobIn(v1::JOB_STATE_SUCCEEDED)};
  sdk::ClientOptions options = NoRetries(a.address() + "," + b.address());
  options.max_attempts = 2;  // the watch's own resume after a broken stream
  auto client = sdk::Client::Connect(options);
  ASSERT_TRUE(client.ok()) << client.status();
  std::vector<sdk::JobState> seen;
  absl::StatusOr<sdk::JobUpdate> done =
      (*client)->WatchJob("job-1", [&](const sdk::JobUpdate& u) { seen.push_back(u.state); });
  ASSERT_TRUE(done.ok()) << done.status();
  EXPECT_EQ(done->state, sdk::JobState::kSucceeded);
  EXPECT_EQ(Calls(a, &FakeReplica::watch_calls), 1);
  EXPECT_EQ(Calls(b, &FakeReplica::watch_calls), 1);
  EXPECT_EQ(Calls(b, &FakeReplica::get_job_calls), 1);  // the resume's catch-up
  EXPECT_EQ(seen, (std::vector<sdk::JobState>{sdk::JobState::kQueued, sdk::JobState::kRunning,
                                              sdk::JobState::kSucceeded}));
}

TEST(Failover, ConnectToNoReplicaNamesEachAddress) {
  const std::string a = "127.0.0.1:" + std::to_string(UnusedPort());
  const std::string b = "127.0.0.1:" + std::to_string(UnusedPort());
  auto client = sdk::Client::Connect(NoRetries(a + "," + b));
  ASSERT_FALSE(client.ok());
  EXPECT_EQ(client.status().code(), absl::StatusCode::kUnavailable);
  const std::string message(client.status().message());
  EXPECT_NE(message.find(a + ": connection refused"), std::string::npos) << message;
  EXPECT_NE(message.find(b + ": connection refused"), std::string::npos) << message;
}

TEST(Failover, MalformedListsAreRefusedByEveryFrontDoor) {
  const std::string bad = "127.0.0.1:1,,127.0.0.1:2";
  absl::Status sdk = sdk::Client::Connect(NoRetries(bad)).status();
  EXPECT_EQ(sdk.code(), absl::StatusCode::kInvalidArgument) << sdk;
  EXPECT_NE(sdk.message().find("ClientOptions.server: address 2"), std::string::npos) << sdk;

  const fs::path dir = fs::temp_directory_path() / ("impostor_failover_" + std::to_string(::getpid()));
  sdk::CacheOptions cache_options;
  cache_options.server = bad;
  cache_options.dir = dir;
  absl::Status cache = sdk::Cache::Open(cache_options).status();
  EXPECT_EQ(cache.code(), absl::StatusCode::kInvalidArgument) << cache;
  EXPECT_NE(cache.message().find("CacheOptions.server: address 2"), std::string::npos) << cache;

  impostor_cache_options c;
  impostor_cache_options_init(&c);
  c.server = "bake.lan";
  const std::string dir_string = dir.string();
  c.dir = dir_string.c_str();
  impostor_cache* handle = nullptr;
  EXPECT_EQ(impostor_cache_open(&c, &handle), IMPOSTOR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(impostor_last_error()).find("\"bake.lan\" has no port"), std::string::npos)
      << impostor_last_error();
  EXPECT_EQ(handle, nullptr);

  absl::StatusOr<cli::CliArgs> args = cli::ParseCliArgs({"status", "job-1", "--server", bad}, nullptr);
  ASSERT_FALSE(args.ok());
  EXPECT_NE(args.status().message().find("--server: address 2"), std::string::npos) << args.status();
  fs::remove_all(dir);
}

}  // namespace
}  // namespace impostor
