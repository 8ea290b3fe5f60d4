// The issue-15 multi-host test: PostgreSQL, two server replicas and three
// workers, each on its own host (a Linux network namespace, joined by a
// bridge: tests/support/netns.h), plus two client hosts.
//  - Both clients submit the same 200 small bakes (distinct cache keys: the
//    resolution varies), one through replica 1 first, the other through
//    replica 2 first (`impostor bake-batch --server a,b`), so identical
//    requests meet at both replicas at once.
//  - Replica 1 is killed with SIGKILL and started again twice, each time
//    when the first client has reported a given number of finished bakes
//    (progress, not time).
//  - Every bake succeeds for both clients, and from the database: one bake
//    (one leader job) per cache key, every job succeeded, and a key leased
//    more than once only after its earlier lease expired (each attempt's
//    history entry says so, and the next lease started after it ended).
//  - The results are byte-identical between the clients and to a
//    single-node run (SQLite, one server, local workers) of every tenth
//    request.
// Needs root and PostgreSQL 15; skipped with the reason otherwise. CTest
// labels netns, postgres, slow.
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "impostor/v1/types.pb.h"
#include "tests/integration/netns_fixture.h"
#include "tests/support/postgres_instance.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::AssetsDir;
using testing::BinaryDir;
using testing::ChildProcess;
using testing::PostgresInstance;
using testing::TestNetwork;

constexpr char kBox[] = "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb";
constexpr int kPgPort = 5432;  // PostgreSQL on the database host
constexpr int kBakes = 200;
constexpr int kFirstKillAfter = 40;    // replica 1 is killed when client A has this many results
constexpr int kSecondKillAfter = 110;  // and again here
constexpr int kReferenceEvery = 10;    // the single-node run bakes every tenth request
constexpr int kLeaseTimeoutS = 10;
// The files compared byte for byte (manifest.json carries baked_by, the
// worker's name, which differs between runs by design).
const char* const kCompared[] = {"albedo_alpha.png", "normal_depth.png"};

std::string Name(int i) { return absl::StrCat("r", 64 + i); }

class NetnsMultiHost : public testing::NetnsTest {
 protected:
  void SetUp() override {
    if (!fs::exists("/usr/lib/postgresql/15/bin/initdb") && std::getenv("IMPOSTOR_PG_BIN") == nullptr) {
      GTEST_SKIP() << "needs PostgreSQL 15 (postgresql-15)";
    }
    NetnsTest::SetUp();
  }

  // The batch spec: `count` bakes of one small asset, resolution 64 + i.
  fs::path WriteSpec(int every, int count = kBakes) {
    nlohmann::json assets = nlohmann::json::array();
    for (int i = 0; i < count; i += every) {
      assets.push_back({{"path", (AssetsDir() / kBox).string()}, {"name", Name(i)}, {"resolution", 64 + i}});
    }
    const fs::path spec = dir_ / absl::StrCat("spec_", count, "_every_", every, ".json");
    std::ofstream(spec) << nlohmann::json({{"defaults", {{"frames", 3}, {"quality_views", 0}}}, {"assets", assets}})
                               .dump();
    return spec;
  }

  // PostgreSQL on `db`, with an empty database "farm".
  std::unique_ptr<PostgresInstance> StartDatabase(const TestNetwork::Host& db) {
    PostgresInstance::Options options;
    options.tcp_address = db.address;
    options.port = kPgPort;
    options.start_prefix = net_->Exec(db, {});
    auto pg = PostgresInstance::Start(options);
    if (!pg.ok()) throw std::runtime_error("PostgreSQL: " + std::string(pg.status().message()));
    if (absl::Status s = (*pg)->CreateDatabase("farm"); !s.ok()) throw std::runtime_error(std::string(s.message()));
    return std::move(*pg);
  }

  // With --database the replicas keep their tokens in that database, so the
  // tokens are created there once, from a host on the bridge (the database is
  // reachable only inside the namespaces). Each replica still gets its own
  // --data; the blob dir is shared.
  std::string CreateToken(const TestNetwork::Host& on, const std::string& database_url, const std::string& role,
                          const std::string& name) {
    const testing::ToolRun run =
        testing::RunTool(net_->Exec(on, {(BinaryDir() / "impostor-server").string(), "token", "create",
                                         "--database=" + database_url, "--role=" + role, "--name=" + name}),
                         testing::kStartTimeout);
    EXPECT_EQ(run.exit_code, 0) << "token create " << role << " " << name << ": " << run.err;
    return run.out.substr(0, run.out.find('\n'));
  }

  void CreateTokens(const TestNetwork::Host& on, const std::string& database_url) {
    fs::create_directories(dir_ / "data1");
    fs::create_directories(dir_ / "data2");
    std::ofstream(dir_ / "worker.token") << CreateToken(on, database_url, "worker", "netns-workers") << "\n";
    std::ofstream(dir_ / "submitter.token") << CreateToken(on, database_url, "submitter", "netns-clients") << "\n";
    fs::create_directories(dir_ / "blobs");
  }

  std::unique_ptr<ChildProcess> StartReplica(const TestNetwork::Host& host, const fs::path& data,
                                             const std::string& database_url, const std::string& extra_flag = "") {
    testing::ProcessOptions options;
    options.name = "server-" + host.name;
    std::vector<std::string> argv = {(BinaryDir() / "impostor-server").string(), "--listen=" + Address(host),
                                     "--data=" + data.string(), "--database=" + database_url,
                                     "--blob-dir=" + (dir_ / "blobs").string(), "--local-workers=0",
                                     absl::StrCat("--lease-timeout-s=", kLeaseTimeoutS), "--log-level=info"};
    if (!extra_flag.empty()) argv.push_back(extra_flag);
    auto server = std::make_unique<ChildProcess>(net_->Exec(host, argv), options);
    if (server->ReadLineContaining("listening on").empty()) {
      server->DumpLogTail();
      throw std::runtime_error("replica on " + host.name + " did not start");
    }
    return server;
  }

  std::unique_ptr<ChildProcess> StartBatch(const TestNetwork::Host& host, const std::string& servers,
                                           const fs::path& spec, const fs::path& out) {
    testing::ProcessOptions options;
    options.name = "batch-" + host.name;
    return std::make_unique<ChildProcess>(
        net_->Exec(host, {(BinaryDir() / "impostor").string(), "bake-batch", spec.string(), "--out", out.string(),
                          "--server", servers, "--token-file", (dir_ / "submitter.token").string(), "--json"}),
        options);
  }

  // Reads batch `batch`'s JSON lines until `count` more asset lines came;
  // records each asset's status and cache key.
  void ReadAssets(ChildProcess& batch, int count, std::map<std::string, nlohmann::json>* seen) {
    for (int i = 0; i < count; ++i) {
      const std::string line = batch.ReadLineContaining("\"type\":\"asset\"", testing::kExitTimeout);
      ASSERT_FALSE(line.empty()) << "batch " << batch.name() << " stopped after " << seen->size() << " results";
      nlohmann::json j = nlohmann::json::parse(line);
      (*seen)[j["name"].get<std::string>()] = j;
    }
  }

  static void ParseAssets(const std::string& text, std::map<std::string, nlohmann::json>* seen) {
    for (absl::string_view line : absl::StrSplit(text, '\n')) {
      if (line.find("\"type\":\"asset\"") == absl::string_view::npos) continue;
      nlohmann::json j = nlohmann::json::parse(line);
      (*seen)[j["name"].get<std::string>()] = j;
    }
  }

  static std::string Query(PostgresInstance& pg, const std::string& sql) {
    auto out = pg.Query("farm", sql);
    EXPECT_TRUE(out.ok()) << out.status();
    return out.ok() ? std::string(absl::StripTrailingAsciiWhitespace(*out)) : std::string("?");
  }

  // Checks every bake's (leader job's) lease history in the database: only
  // an expired (or released) lease is followed by another, which began after
  // it ended; the last one succeeded; the lease_expiries column agrees.
  // Returns how many leases expired.
  int CheckLeaseHistories(PostgresInstance& pg, int bakes) {
    const std::string rows =
        Query(pg, "SELECT job_id || ' ' || lease_expiries || ' ' || replace(encode(job, 'base64'), E'\\n', '') "
              "FROM jobs WHERE leader_job_id = ''");
    int jobs_checked = 0, expiries = 0;
    std::vector<std::string> records = absl::StrSplit(rows, '\n', absl::SkipEmpty());
    for (const std::string& record : records) {
      std::vector<std::string> parts = absl::StrSplit(record, ' ');
      std::string bytes;
      v1::Job job;
      if (parts.size() != 3 || !absl::Base64Unescape(parts[2], &bytes) || !job.ParseFromString(bytes) ||
          job.attempt_history().empty()) {
        ADD_FAILURE() << "unreadable job row or no lease history: " << record.substr(0, 200);
        continue;
      }
      ++jobs_checked;
      const auto& history = job.attempt_history();
      int expired = 0;
      for (int i = 0; i + 1 < history.size(); ++i) {
        EXPECT_TRUE(history[i].outcome() == v1::JobAttempt::OUTCOME_LEASE_EXPIRED ||
                    history[i].outcome() == v1::JobAttempt::OUTCOME_RELEASED)
            << parts[0] << " was leased again after attempt " << i << " ended with " << history[i].outcome();
        EXPECT_GE(history[i + 1].leased_ms(), history[i].ended_ms()) << parts[0] << " leased twice at once";
        if (history[i].outcome() == v1::JobAttempt::OUTCOME_LEASE_EXPIRED) ++expired;
      }
      EXPECT_EQ(history[history.size() - 1].outcome(), v1::JobAttempt::OUTCOME_SUCCEEDED) << parts[0];
      EXPECT_EQ(std::to_string(expired), parts[1]) << parts[0] << ": lease_expiries and the history disagree";
      expiries += expired;
    }
    EXPECT_EQ(jobs_checked, bakes);
    return expiries;
  }

  // The run the database-outage tests disturb: PostgreSQL on its own host,
  // two replicas, two workers (one starting on each replica) and a client's
  // bake-batch of `jobs` bakes through replica 1 first.
  struct OutageRun {
    TestNetwork::Host db;
    std::unique_ptr<PostgresInstance> pg;  // declared first: stopped after the processes
    std::unique_ptr<ChildProcess> replicas[2];
    std::unique_ptr<ChildProcess> workers[2];
    std::unique_ptr<ChildProcess> batch;
    std::map<std::string, nlohmann::json> seen;
  };
  // Starts it and reads the batch's first `first` results.
  void StartOutageRun(int jobs, int first, OutageRun* run) {
    run->db = Host("db");
    const TestNetwork::Host s[2] = {Host("replica1"), Host("replica2")};
    const TestNetwork::Host wh[2] = {Host("worker1"), Host("worker2")};
    const TestNetwork::Host ca = Host("client-a");
    run->pg = StartDatabase(run->db);
    const std::string url = run->pg->Url("farm", /*tcp=*/true);
    CreateTokens(s[0], url);
    run->replicas[0] = StartReplica(s[0], dir_ / "data1", url);
    run->replicas[1] = StartReplica(s[1], dir_ / "data2", url);
    const std::string a1 = Address(s[0]), a2 = Address(s[1]);
    run->workers[0] = StartWorker(wh[0], a1 + "," + a2);
    run->workers[1] = StartWorker(wh[1], a2 + "," + a1);
    run->batch = StartBatch(ca, a1 + "," + a2, WriteSpec(1, jobs), dir_ / "out");
    ReadAssets(*run->batch, first, &run->seen);
  }
  // Reads the rest: every bake succeeded, every job row succeeded, one
  // bake per request, and the lease histories check out. Returns how many
  // leases expired (-1 when the batch failed).
  int FinishOutageRun(OutageRun& run, int jobs) {
    std::string rest;
    const int exit_code = run.batch->Wait(&rest);
    EXPECT_EQ(exit_code, 0) << rest << run.replicas[0]->Stderr();
    if (exit_code != 0) return -1;
    ParseAssets(rest, &run.seen);
    EXPECT_EQ(run.seen.size(), static_cast<size_t>(jobs));
    for (const auto& [name, asset] : run.seen) EXPECT_EQ(asset["status"], "succeeded") << asset.dump();
    EXPECT_EQ(Query(*run.pg, "SELECT count(*) FROM jobs WHERE state <> 3"), "0");
    EXPECT_EQ(Query(*run.pg, "SELECT count(*) FROM jobs WHERE leader_job_id = ''"), std::to_string(jobs));
    return CheckLeaseHistories(*run.pg, jobs);
  }
};

TEST_F(NetnsMultiHost, TwoHundredBakesSurviveAReplicaKilledTwice) {
  const TestNetwork::Host db = Host("db");
  const TestNetwork::Host s1 = Host("replica1");
  const TestNetwork::Host s2 = Host("replica2");
  const TestNetwork::Host wh[3] = {Host("worker1"), Host("worker2"), Host("worker3")};
  const TestNetwork::Host ca = Host("client-a");
  const TestNetwork::Host cb = Host("client-b");

  auto pg = StartDatabase(db);
  const std::string url = pg->Url("farm", /*tcp=*/true);
  CreateTokens(s1, url);

  auto r1 = StartReplica(s1, dir_ / "data1", url);
  auto r2 = StartReplica(s2, dir_ / "data2", url);
  const std::string a1 = Address(s1), a2 = Address(s2);
  // Workers 1 and 3 start on replica 1 (the one killed), worker 2 on replica 2.
  std::unique_ptr<ChildProcess> workers[3] = {StartWorker(wh[0], a1 + "," + a2), StartWorker(wh[1], a2 + "," + a1),
                                              StartWorker(wh[2], a1 + "," + a2)};

  const fs::path spec = WriteSpec(1);
  auto batch_a = StartBatch(ca, a1 + "," + a2, spec, dir_ / "out_a");
  auto batch_b = StartBatch(cb, a2 + "," + a1, spec, dir_ / "out_b");

  std::map<std::string, nlohmann::json> seen_a, seen_b;
  ReadAssets(*batch_a, kFirstKillAfter, &seen_a);
  r1->KillAndReap();
  r1 = StartReplica(s1, dir_ / "data1", url);
  ReadAssets(*batch_a, kSecondKillAfter - kFirstKillAfter, &seen_a);
  r1->KillAndReap();
  r1 = StartReplica(s1, dir_ / "data1", url);

  std::string rest_a, rest_b;
  ASSERT_EQ(batch_a->Wait(&rest_a), 0) << rest_a;
  ASSERT_EQ(batch_b->Wait(&rest_b), 0) << rest_b;
  ParseAssets(rest_a, &seen_a);
  ParseAssets(rest_b, &seen_b);

  // Every bake succeeded for both clients, with the same cache key.
  ASSERT_EQ(seen_a.size(), static_cast<size_t>(kBakes));
  ASSERT_EQ(seen_b.size(), static_cast<size_t>(kBakes));
  std::set<std::string> keys;
  for (int i = 0; i < kBakes; ++i) {
    const nlohmann::json& a = seen_a[Name(i)];
    const nlohmann::json& b = seen_b[Name(i)];
    EXPECT_EQ(a["status"], "succeeded") << a.dump();
    EXPECT_EQ(b["status"], "succeeded") << b.dump();
    EXPECT_EQ(a["cache_key"], b["cache_key"]) << Name(i);
    if (a["cache_key"].is_string()) keys.insert(a["cache_key"].get<std::string>());
    for (const char* file : kCompared) {
      const std::string bytes = testing::ReadFileBytes(dir_ / "out_a" / Name(i) / file);
      EXPECT_FALSE(bytes.empty()) << Name(i) << "/" << file;
      EXPECT_EQ(bytes, testing::ReadFileBytes(dir_ / "out_b" / Name(i) / file)) << Name(i) << "/" << file;
    }
  }
  EXPECT_EQ(keys.size(), static_cast<size_t>(kBakes));
  // The replica was really killed while it served: its clients and workers
  // moved to the other.
  int failovers = 0;
  for (auto& w : workers) failovers += w->CountInLog("event=server_failover from=" + a1);
  EXPECT_GE(failovers, 1) << workers[0]->Stderr();

  // From the database. Leader jobs (leader_job_id = '') are the bakes;
  // followers share a leader's bake.
  EXPECT_EQ(Query(*pg, "SELECT count(*) FROM jobs WHERE state <> 3"), "0")
      << "every job succeeded; the others (job, state, leader, client, request_id, created_ms, leader's state):\n"
      << Query(*pg,
               "SELECT j.job_id || ' ' || j.state || ' ' || j.leader_job_id || ' ' || j.client_id || ' ' || "
               "j.request_id || ' ' || j.created_ms || ' ' || coalesce(l.state::text, '-') FROM jobs j "
               "LEFT JOIN jobs l ON l.job_id = j.leader_job_id WHERE j.state <> 3");
  EXPECT_EQ(Query(*pg, "SELECT count(*) FROM jobs WHERE leader_job_id = ''"), std::to_string(kBakes));
  EXPECT_EQ(Query(*pg, "SELECT count(DISTINCT cache_key) FROM jobs WHERE leader_job_id = ''"), std::to_string(kBakes));
  const int expiries = CheckLeaseHistories(*pg, kBakes);
  std::printf("[ multi-host ] %d bakes, %d expired leases re-leased, %d worker failovers\n", kBakes, expiries,
              failovers);

  // The single-node reference: one server on SQLite, local workers, every
  // tenth request; the multi-host bytes equal its bytes.
  for (auto& w : workers) w->KillAndReap();
  testing::ServerProcess single(2);
  const testing::ToolRun ref = testing::RunTool({(BinaryDir() / "impostor").string(), "bake-batch",
                                                 WriteSpec(kReferenceEvery).string(), "--out",
                                                 (dir_ / "single").string(), "--server", single.address(), "--json"});
  ASSERT_EQ(ref.exit_code, 0) << ref.err;
  for (int i = 0; i < kBakes; i += kReferenceEvery) {
    for (const char* file : kCompared) {
      EXPECT_EQ(testing::ReadFileBytes(dir_ / "single" / Name(i) / file),
                testing::ReadFileBytes(dir_ / "out_a" / Name(i) / file))
          << Name(i) << "/" << file;
    }
  }
}

// The database restarted (pg_ctl stop -m fast, then start: every replica's
// connections drop) while 30 bakes run through two replicas: no job is
// lost, every bake succeeds, and each was leased once or after an expiry.
TEST_F(NetnsMultiHost, ADatabaseRestartMidRunLosesNoJob) {
  constexpr int kJobs = 30;
  constexpr int kRestartAfter = 10;
  OutageRun run;
  StartOutageRun(kJobs, kRestartAfter, &run);
  ASSERT_FALSE(HasFatalFailure());
  ASSERT_TRUE(run.pg->Restart().ok());
  FinishOutageRun(run, kJobs);
  // The restart really reached the replicas: their pools lost connections.
  int lost = 0;
  for (auto& r : run.replicas) lost += r->CountInLog("event=database_unavailable");
  EXPECT_GE(lost, 1) << run.replicas[0]->Stderr();
}

// A watch waiting for a queued bake over a link that died without a reset
// (the replica's host cut off: packets vanish): with --keepalive-seconds 2
// the client's pings go unanswered, it gives the connection up within
// 2 + 2 s, and the watch resumes on the other replica, where the bake
// finishes once a worker comes. Without pings such a watch sits on the
// dead connection for TCP's ~15 min; with the SDK's default (20 s) it
// misses the deadline below, so the deadline tests the flag (checked by
// running this test with --keepalive-seconds=20: it fails).
TEST_F(NetnsMultiHost, AQuietWatchOverACutLinkMovesToTheOtherReplica) {
  const TestNetwork::Host db = Host("db");
  const TestNetwork::Host s1 = Host("replica1");
  const TestNetwork::Host s2 = Host("replica2");
  const TestNetwork::Host worker_host = Host("worker1");
  const TestNetwork::Host client = Host("client-a");
  auto pg = StartDatabase(db);
  const std::string url = pg->Url("farm", /*tcp=*/true);
  CreateTokens(s1, url);
  auto r1 = StartReplica(s1, dir_ / "data1", url, "--keepalive-seconds=2");
  auto r2 = StartReplica(s2, dir_ / "data2", url, "--keepalive-seconds=2");
  const std::string a1 = Address(s1), a2 = Address(s2);

  // No worker yet: the bake stays queued and the client's WatchJob on
  // replica 1 hears nothing.
  testing::ProcessOptions options;
  options.name = "bake-client";
  options.env = {"IMPOSTOR_LOG=debug"};  // the SDK logs its failover at debug
  ChildProcess bake(net_->Exec(client, {(BinaryDir() / "impostor").string(), "bake", (AssetsDir() / kBox).string(),
                                        "--out", (dir_ / "out").string(), "--server", a1 + "," + a2, "--token-file",
                                        (dir_ / "submitter.token").string(), "--frames=3", "--resolution=64",
                                        "--quality-views=0", "--keepalive-seconds=2", "--json"}),
                    options);
  ASSERT_TRUE(r1->WaitForLog("event=submit")) << "the client did not submit through replica 1";
  ASSERT_TRUE(bake.WaitForLog("] queued")) << "the watch did not start";

  // The client notices within one ping interval plus the ping timeout (or,
  // when it had a frame in flight at the cut, within the ping timeout: gRPC
  // sets TCP_USER_TIMEOUT to it): 2-4 s here, 10-30 s at the default 20,
  // 20-330 s before this setting existed.
  ASSERT_TRUE(net_->SetLink(s1, false).ok());
  ASSERT_TRUE(bake.WaitForLog("event=server_failover from=" + a1 + " to=" + a2, 1, std::chrono::seconds(7)))
      << "the quiet watch did not notice the cut link within 7 s";

  auto worker = StartWorker(worker_host, a2);
  std::string out;
  ASSERT_EQ(bake.Wait(&out), 0) << out;
  const nlohmann::json result = nlohmann::json::parse(out.substr(0, out.find('\n')));
  EXPECT_EQ(result["error"], nullptr) << out;
  EXPECT_FALSE(testing::ReadFileBytes(dir_ / "out" / "albedo_alpha.png").empty());
  EXPECT_EQ(worker->CountInLog("event=job_done"), 1) << worker->Stderr();
  EXPECT_EQ(Query(*pg, "SELECT count(*) FROM jobs"), "1") << "the watch resumed the same job, no second submit";
  ASSERT_TRUE(net_->SetLink(s1, true).ok());
}

// A replica cut off from the network (its host's link down: packets
// vanish, nobody sees a reset) while it holds the maintenance lock (lease
// expiry, eviction, retention): the database ends its session within
// about --database-dead-link-seconds (20 s by default), which frees the
// advisory lock, and the other replica takes maintenance over; the cut
// replica gives up its own end of the lock rather than hang. Before the
// dead-link settings (server/store/postgres/pg_dead_link.h) PostgreSQL kept the
// dead session for the kernel's 2 h of keepalive silence, so nobody swept
// expired leases that long (checked by running this test without them: the
// deadline below fails). At the default, like a real deployment.
TEST_F(NetnsMultiHost, AReplicaCutOffFromTheDatabaseHandsOverMaintenance) {
  // The bigint key of the maintenance lock (PostgresMaintenanceLockKey(),
  // server/store/postgres/postgres_job_store.cc): pg_locks shows it as classid
  // (high 32 bits) and objid (low 32 bits).
  constexpr char kHolder[] =
      "SELECT coalesce(string_agg(host(a.client_addr), ','), 'none') FROM pg_locks l JOIN pg_stat_activity a "
      "ON a.pid = l.pid WHERE l.locktype = 'advisory' AND l.granted AND "
      "(l.classid::bigint << 32) + l.objid::bigint = 7596851770424586099";
  // The database ends a dead session after about 20 s, the replicas retry
  // the lock every second; generous for a loaded machine, far below 2 h.
  constexpr auto kHandOver = std::chrono::seconds(120);
  const TestNetwork::Host db = Host("db");
  const TestNetwork::Host s1 = Host("replica1");
  const TestNetwork::Host s2 = Host("replica2");
  auto pg = StartDatabase(db);
  const std::string url = pg->Url("farm", /*tcp=*/true);
  CreateTokens(s1, url);

  auto r1 = StartReplica(s1, dir_ / "data1", url);
  ASSERT_TRUE(r1->WaitForLog("event=maintenance_lock_acquired")) << r1->Stderr();
  auto r2 = StartReplica(s2, dir_ / "data2", url);
  EXPECT_EQ(Query(*pg, kHolder), s1.address) << "replica 1 holds the lock before the cut";

  ASSERT_TRUE(net_->SetLink(s1, false).ok());
  ASSERT_TRUE(r2->WaitForLog("event=maintenance_lock_acquired", 1, kHandOver))
      << "the database did not free the cut replica's lock\n" << r2->Stderr();
  EXPECT_EQ(Query(*pg, kHolder), s2.address);
  // The cut replica notices too (its statement's bytes go unacknowledged)
  // instead of waiting on TCP's retransmissions with its scheduler locked.
  EXPECT_TRUE(r1->WaitForLog("event=maintenance_lock_lost", 1, kHandOver)) << r1->Stderr();
  EXPECT_EQ(r1->CountInLog("event=maintenance_lock_acquired"), 1) << "replica 1 did not take it back while cut";
  ASSERT_TRUE(net_->SetLink(s1, true).ok());
}

// One DNS name with a record per replica (the other way to list
// replicas; docs/scaling.md): the client and the worker know only
// "bake.farm.test:50051", which resolves to both replicas (each host's own
// /etc/hosts, TestNetwork::SetHostNames; gRPC's resolver returns both
// records and its pick_first policy tries them in order). The client
// submits while only replica 1 is up, so its watch is on replica 1; replica
// 1 is SIGKILLed; the watch resumes through the same name on replica 2,
// where a worker (also given only the name) bakes the job. The same job
// finishes: no second submit.
TEST_F(NetnsMultiHost, ADnsNameWithARecordPerReplicaSurvivesAKilledReplica) {
  constexpr char kName[] = "bake.farm.test";
  const TestNetwork::Host db = Host("db");
  const TestNetwork::Host s1 = Host("replica1");
  const TestNetwork::Host s2 = Host("replica2");
  const TestNetwork::Host worker_host = Host("worker1");
  const TestNetwork::Host client = Host("client-a");
  for (const TestNetwork::Host& h : {worker_host, client}) {
    ASSERT_TRUE(net_->SetHostNames(h, {{s1.address, kName}, {s2.address, kName}}).ok());
  }
  const std::string target = absl::StrCat(kName, ":", kPort);
  auto pg = StartDatabase(db);
  const std::string url = pg->Url("farm", /*tcp=*/true);
  CreateTokens(s1, url);
  auto r1 = StartReplica(s1, dir_ / "data1", url);

  testing::ProcessOptions options;
  options.name = "bake-client";
  ChildProcess bake(net_->Exec(client, {(BinaryDir() / "impostor").string(), "bake", (AssetsDir() / kBox).string(),
                                        "--out", (dir_ / "out").string(), "--server", target, "--token-file",
                                        (dir_ / "submitter.token").string(), "--frames=3", "--resolution=64",
                                        "--quality-views=0", "--json"}),
                    options);
  ASSERT_TRUE(r1->WaitForLog("event=submit")) << "the client did not reach replica 1 by name";
  ASSERT_TRUE(bake.WaitForLog("] queued")) << "the watch did not start";

  auto r2 = StartReplica(s2, dir_ / "data2", url);
  r1->KillAndReap();
  auto worker = StartWorker(worker_host, target);
  std::string out;
  ASSERT_EQ(bake.Wait(&out), 0) << out << bake.Stderr();
  const nlohmann::json result = nlohmann::json::parse(out.substr(0, out.find('\n')));
  EXPECT_EQ(result["error"], nullptr) << out;
  EXPECT_FALSE(testing::ReadFileBytes(dir_ / "out" / "albedo_alpha.png").empty());
  EXPECT_EQ(worker->CountInLog("event=job_done"), 1) << worker->Stderr();
  EXPECT_EQ(Query(*pg, "SELECT count(*) FROM jobs"), "1") << "the watch resumed the same job, no second submit";
  EXPECT_EQ(Query(*pg, "SELECT count(*) FROM jobs WHERE state = 3"), "1") << "it succeeded";
}

// The database host's link cut (packets dropped, no reset) while 30 bakes
// run through two replicas, then restored: a statement already sent on a
// replica's connection fails within --database-dead-link-seconds (20 s by
// default; libpq's "could not receive data from server: Connection timed
// out") instead of waiting on TCP's retransmissions, the replicas reconnect
// once the link is back, and no job is lost: every bake succeeds, each
// leased again only after an expiry. The cut lasts until a replica has
// logged that (progress, not time).
TEST_F(NetnsMultiHost, ADatabaseLinkCutMidRunLosesNoJob) {
  constexpr int kJobs = 30;
  constexpr int kCutAfter = 10;
  // The 20 s dead-link budget, with room for a loaded machine. Without the
  // dead-link settings such a statement waits ~15 min on TCP's
  // retransmissions (new connections fail sooner, "No route to host", but
  // say so otherwise): the deadline fails (checked).
  constexpr auto kNoticed = std::chrono::seconds(75);
  constexpr char kStatementTimedOut[] = "could not receive data from server: Connection timed out";
  OutageRun run;
  StartOutageRun(kJobs, kCutAfter, &run);
  ASSERT_FALSE(HasFatalFailure());
  ASSERT_TRUE(net_->SetLink(run.db, false).ok());
  // Either replica may be the first to run a statement into the cut: one
  // deadline for both (a line logged meanwhile by the second is found at
  // once).
  const auto deadline = std::chrono::steady_clock::now() + kNoticed;
  bool noticed = false;
  for (auto& r : run.replicas) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (r->WaitForLog(kStatementTimedOut, 1, std::max(left, std::chrono::milliseconds(1)))) {
      noticed = true;
      break;
    }
  }
  ASSERT_TRUE(net_->SetLink(run.db, true).ok());
  EXPECT_TRUE(noticed) << "no replica gave up a statement sent into the cut link\n"
                       << run.replicas[0]->Stderr() << run.replicas[1]->Stderr();
  const int expiries = FinishOutageRun(run, kJobs);
  std::printf("[ multi-host ] database link cut: %d expired leases re-leased\n", expiries);
}

}  // namespace
}  // namespace impostor
