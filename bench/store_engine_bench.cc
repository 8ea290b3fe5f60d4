// store_engine_bench: the scheduler's storage cost per engine, in one run:
// submits/s (new bakes queued), leases/s and cache-hit answers/s through
// BakeScheduler (no gRPC, no worker), for SQLite, PostgreSQL with one
// replica, and PostgreSQL with two replicas sharing the work, printed as
// rates and as ratios to SQLite. PostgreSQL is a throwaway server started
// here (tests/support/postgres_instance.h). Not a test: prints figures.
//
// Usage: store_engine_bench [JOBS]   (default 1000 per phase)
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <thread>
#include <vector>

#include <spdlog/spdlog.h>

#include "absl/strings/numbers.h"
#include "bench/bench_args.h"
#include "absl/strings/str_cat.h"
#include "common/util/sha256.h"
#include "server/scheduler/bake_scheduler.h"
#include "server/store/postgres/postgres_job_store.h"
#include "server/store/sqlite/sqlite_job_store.h"
#include "tests/support/postgres_instance.h"

namespace {

using namespace impostor;
using Clock = std::chrono::steady_clock;

struct Rates {
  double submits = 0, leases = 0, hits = 0;
};

v1::Digest Put(BlobStore& blobs, const std::string& bytes) {
  v1::Digest d;
  d.set_hash(Sha256Hex(bytes));
  d.set_size_bytes(static_cast<int64_t>(bytes.size()));
  (void)blobs.Put({d.hash(), d.size_bytes()}, bytes);
  return d;
}

v1::SubmitBakeRequest Request(const v1::Digest& mesh) {
  v1::SubmitBakeRequest r;
  r.mutable_mesh()->mutable_entry()->set_path("model.glb");
  *r.mutable_mesh()->mutable_entry()->mutable_digest() = mesh;
  return r;
}

// Runs `work(replica, i)` for i in [0, n) split over the replicas, one
// thread each; returns operations per second.
template <class F>
double Timed(int n, int replicas, F work) {
  const auto start = Clock::now();
  std::vector<std::thread> threads;
  for (int r = 0; r < replicas; ++r) {
    threads.emplace_back([&, r] {
      for (int i = r; i < n; i += replicas) work(r, i);
    });
  }
  for (auto& t : threads) t.join();
  return n / std::chrono::duration<double>(Clock::now() - start).count();
}

Rates Measure(std::vector<JobStore*> stores, BlobStore& blobs, int n, const std::string& tag) {
  std::vector<std::unique_ptr<BakeScheduler>> replicas;
  for (JobStore* s : stores) replicas.push_back(std::make_unique<BakeScheduler>(s, &blobs, SchedulerOptions{}));
  const int k = static_cast<int>(replicas.size());
  std::vector<v1::Digest> meshes;
  for (int i = 0; i < n; ++i) meshes.push_back(Put(blobs, absl::StrCat(tag, " mesh ", i)));
  Rates rates;
  std::vector<v1::LeasedJob> leased(n);
  rates.submits = Timed(n, k, [&](int r, int i) {
    if (!replicas[r]->Submit(Request(meshes[i]), absl::StrCat("client-", i % 4)).ok()) std::abort();
  });
  rates.leases = Timed(n, k, [&](int r, int i) {
    v1::LeaseJobRequest req;
    req.set_worker_id(absl::StrCat("w", r));
    auto job = replicas[r]->Lease(req, Clock::now(), nullptr);
    if (!job.ok() || !job->has_value()) std::abort();
    leased[i] = **job;
  });
  // Complete them all (untimed), then every submit is a cache hit.
  const v1::Digest json = Put(blobs, "{}");
  for (int i = 0; i < n; ++i) {
    v1::CompleteJobRequest c;
    c.set_job_id(leased[i].job_id());
    c.set_lease_id(leased[i].lease_id());
    c.mutable_result()->set_cache_key(leased[i].cache_key());
    *c.mutable_result()->mutable_manifest_json() = json;
    v1::MapFile* map = c.mutable_result()->add_maps();
    map->set_file("albedo_alpha.png");
    *map->mutable_digest() = json;
    if (!replicas[0]->Complete(c).ok()) std::abort();
  }
  rates.hits = Timed(n, k, [&](int r, int i) {
    auto resp = replicas[r]->Submit(Request(meshes[i]), "client-hit");
    if (!resp.ok() || !resp->cached()) std::abort();
  });
  return rates;
}

}  // namespace

int main(int argc, char** argv) {
  int n = 1000;
  std::vector<std::string> jobs;
  impostor::bench::BenchArgs("store_engine_bench", "Job-store throughput of the SQLite and PostgreSQL engines.")
      .Positional("JOBS", &jobs, "operations per phase (default 1000)")
      .ParseOrExit(argc, argv);
  if (!jobs.empty() && (jobs.size() > 1 || !absl::SimpleAtoi(jobs[0], &n) || n < 1)) {
    std::fprintf(stderr, "store_engine_bench: JOBS must be one whole number >= 1\n");
    return 2;
  }
  spdlog::set_level(spdlog::level::warn);
  const auto dir = std::filesystem::temp_directory_path() / ("store_engine_bench_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  auto blobs = BlobStore::Open(dir / "blobs");
  auto sqlite = SqliteJobStore::Open(dir / "jobs.sqlite3");
  // fsync on, like SQLite's synchronous=FULL: both engines pay for
  // durable commits.
  auto pg = impostor::testing::PostgresInstance::Start({.fsync = true});
  if (!blobs.ok() || !sqlite.ok() || !pg.ok()) {
    std::fprintf(stderr, "setup failed: %s\n", std::string(pg.status().message()).c_str());
    return 1;
  }
  (void)(*pg)->CreateDatabase("one");
  (void)(*pg)->CreateDatabase("two");
  auto one = PostgresJobStore::Open({.url = (*pg)->Url("one")});
  auto two_a = PostgresJobStore::Open({.url = (*pg)->Url("two")});
  auto two_b = PostgresJobStore::Open({.url = (*pg)->Url("two")});
  if (!one.ok() || !two_a.ok() || !two_b.ok()) return 1;
  const Rates s = Measure({sqlite->get()}, **blobs, n, "sqlite");
  const Rates p1 = Measure({one->get()}, **blobs, n, "pg1");
  const Rates p2 = Measure({two_a->get(), two_b->get()}, **blobs, n, "pg2");
  std::printf("store_engine_bench: %d operations per phase (in-process BakeScheduler, %u cores, both engines "
              "fsync every commit; PostgreSQL on a local Unix socket)\n",
              n, std::thread::hardware_concurrency());
  std::printf("%-24s %12s %12s %14s\n", "engine", "submits/s", "leases/s", "cache hits/s");
  for (auto [name, r] : {std::pair{"sqlite", s}, {"postgresql, 1 replica", p1}, {"postgresql, 2 replicas", p2}}) {
    std::printf("%-24s %12.0f %12.0f %14.0f\n", name, r.submits, r.leases, r.hits);
  }
  std::printf("ratio to sqlite:\n");
  for (auto [name, r] : {std::pair{"postgresql, 1 replica", p1}, {"postgresql, 2 replicas", p2}}) {
    std::printf("%-24s %12.2f %12.2f %14.2f\n", name, r.submits / s.submits, r.leases / s.leases, r.hits / s.hits);
  }
  std::filesystem::remove_all(dir);
  return 0;
}
