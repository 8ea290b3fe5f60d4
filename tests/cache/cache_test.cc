// The game-client cache against a real impostor-server on loopback (results
// published through WorkerService, no GPU): downloads, hits without RPCs,
// corruption, single-flight, resumed downloads across a server restart,
// eviction under pins, offline behaviour, Lookup and Prefetch.
#include <signal.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <latch>
#include <map>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>

#include <gtest/gtest.h>

#include "client/cache/cache_testing.h"
#include "impostor/cache.h"
#include "impostor/client.h"
#include "impostor/log.h"
#include "tests/support/published_result.h"
#include "tests/support/server_process.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using sdk::Cache;
using sdk::CachedResult;
using testing::PublishedResult;
using testing::PublishResult;
using testing::ReadFileBytes;
using testing::ServerProcess;

constexpr char kReadBlob[] = "/impostor.v1.AssetService/ReadBlob";
constexpr char kGetResult[] = "/impostor.v1.AssetService/GetResult";
constexpr char kBatchRead[] = "/impostor.v1.AssetService/BatchReadBlobs";

// Counts the RPCs a cache puts on the wire, by method.
class RpcCounter {
 public:
  sdk::TransportHooks Hooks() {
    return {.on_rpc = [this](const std::string& method) {
      std::lock_guard lock(mu_);
      ++counts_[method];
    }};
  }
  int Count(const std::string& method) {
    std::lock_guard lock(mu_);
    return counts_[method];
  }
  int Total() {
    std::lock_guard lock(mu_);
    int total = 0;
    for (const auto& [m, n] : counts_) total += n;
    return total;
  }

 private:
  std::mutex mu_;
  std::map<std::string, int> counts_;
};

sdk::CacheOptions Options(const std::string& server, const fs::path& dir) {
  sdk::CacheOptions o;
  o.server = server;
  o.dir = dir;
  o.max_attempts = 2;
  // These tests are about a server that is gone for good (offline hits, a
  // fast UNAVAILABLE, resuming in a later run): no outage to ride out.
  // tests/integration/outage_test.cc covers the default budget.
  o.max_outage_seconds = 0;
  return o;
}

std::unique_ptr<Cache> OpenCache(const sdk::CacheOptions& options, RpcCounter* counter = nullptr,
                                 sdk::DownloadHooks download = {}) {
  sdk::CacheTestHooks hooks;
  if (counter != nullptr) hooks.transport = counter->Hooks();
  hooks.download = std::move(download);
  auto cache = sdk::CacheFactory::Open(options, hooks);
  EXPECT_TRUE(cache.ok()) << cache.status();
  return cache.ok() ? std::move(*cache) : nullptr;
}

// Every file of `result` holds the bytes the server published.
void ExpectBytes(const CachedResult& result, const PublishedResult& published, const std::string& context) {
  ASSERT_TRUE(result.valid()) << context;
  ASSERT_EQ(result.files().size(), published.files.size()) << context;
  for (const sdk::CachedFile& f : result.files()) {
    const std::string name = f.path.filename().string();
    ASSERT_TRUE(published.files.contains(name)) << context << ": " << name;
    EXPECT_EQ(ReadFileBytes(f.path), published.files.at(name)) << context << ": " << name;
  }
  EXPECT_EQ(result.size_bytes(), published.total_bytes) << context;
  EXPECT_EQ(ReadFileBytes(result.manifest_path()), result.manifest_json()) << context;
}

sdk::BakeSettings Settings(const std::string& layout, uint32_t frames, uint32_t resolution) {
  sdk::BakeSettings settings;
  settings.layout = layout;
  settings.frames = frames;
  settings.resolution = resolution;
  return settings;
}

const std::vector<int64_t> kSmallMaps = {300 << 10, 200 << 10, 100 << 10};

TEST(CacheGet, FirstGetDownloadsAndLaterGetsMakeNoRpc) {
  ServerProcess server(/*local_workers=*/0);
  const PublishedResult published = PublishResult(server, kSmallMaps, 1);
  const fs::path dir = testing::NewTempDir("cache_first_get");
  RpcCounter rpcs;
  auto cache = OpenCache(Options(server.address(), dir), &rpcs);
  ASSERT_NE(cache, nullptr);
  EXPECT_EQ(rpcs.Total(), 0) << "opening the cache must not touch the network";

  auto first = cache->Get(published.key);
  ASSERT_TRUE(first.ok()) << first.status();
  EXPECT_TRUE(first->downloaded());
  ExpectBytes(*first, published, "first get");
  EXPECT_EQ(first->layout(), "octahedral");
  EXPECT_EQ(first->frames(), 3u);
  EXPECT_EQ(first->product(), "atlas") << "a manifest without `product` is an atlas";
  EXPECT_EQ(first->view_count(), 9u);
  ASSERT_NE(first->map("normal_depth"), nullptr);
  EXPECT_EQ(first->map("normal_depth")->format, "png_rgba16");
  EXPECT_EQ(rpcs.Count(kGetResult), 1);
  EXPECT_EQ(rpcs.Count(kBatchRead), 1) << "three maps and manifest.json, all under 1 MiB, in one call";
  EXPECT_EQ(rpcs.Count(kReadBlob), 0);
  const int after_first = rpcs.Total();

  auto second = cache->Get(published.key);
  ASSERT_TRUE(second.ok()) << second.status();
  EXPECT_FALSE(second->downloaded());
  ExpectBytes(*second, published, "second get");
  EXPECT_EQ(rpcs.Total(), after_first) << "a hit must make no RPC";

  // A restarted game (a new Cache on the same directory) hits too.
  RpcCounter fresh_rpcs;
  auto reopened = OpenCache(Options(server.address(), dir), &fresh_rpcs);
  auto third = reopened->Get(published.key);
  ASSERT_TRUE(third.ok()) << third.status();
  ExpectBytes(*third, published, "after reopen");
  EXPECT_EQ(fresh_rpcs.Total(), 0);
  const sdk::CacheStats stats = reopened->Stats();
  EXPECT_EQ(stats.hits, 1);
  EXPECT_EQ(stats.downloads, 0);
}

// One blob under several names (LOD levels that share bytes) is read once,
// installed under every name, and counts as downloaded once, not "resumed"
// (nothing was partial). Released, the result is unpinned at once and
// eviction can take it.
TEST(CacheGet, OneBlobUnderSeveralNamesIsFetchedOnceAndNothingCountsAsResumed) {
  ServerProcess server(/*local_workers=*/0);
  const int64_t size = 64 << 10;
  const PublishedResult published = PublishResult(server, {size, size, size}, 7, /*one_blob=*/true);
  const fs::path dir = testing::NewTempDir("cache_one_blob");
  RpcCounter rpcs;
  auto cache = OpenCache(Options(server.address(), dir), &rpcs);
  {
    auto got = cache->Get(published.key);
    ASSERT_TRUE(got.ok()) << got.status();
    ExpectBytes(*got, published, "one blob, three names");
  }
  EXPECT_EQ(rpcs.Count(kBatchRead), 1) << "the shared map blob and manifest.json, in one call";
  EXPECT_EQ(rpcs.Count(kReadBlob), 0);
  const sdk::CacheStats stats = cache->Stats();
  EXPECT_EQ(stats.bytes_resumed, 0);
  EXPECT_EQ(stats.bytes_downloaded, size + static_cast<int64_t>(published.files.at("manifest.json").size()));
  EXPECT_EQ(stats.pinned_entries, 0) << "no handle is left once the caller's is gone";
  ASSERT_TRUE(cache->CollectGarbage(0).ok());
  EXPECT_EQ(cache->Stats().entries, 0);
}

TEST(CacheGet, AsyncFormsAnswerWithoutBlocking) {
  ServerProcess server(0);
  const PublishedResult published = PublishResult(server, kSmallMaps, 2);
  auto cache = OpenCache(Options(server.address(), testing::NewTempDir("cache_async")));
  auto future = cache->GetAsync(published.key);
  auto got = future.get();
  ASSERT_TRUE(got.ok()) << got.status();
  ExpectBytes(*got, published, "future");

  std::promise<absl::StatusOr<CachedResult>> promise;
  cache->GetAsync(published.key, [&](absl::StatusOr<CachedResult> r) { promise.set_value(std::move(r)); });
  auto hit = promise.get_future().get();
  ASSERT_TRUE(hit.ok()) << hit.status();
  EXPECT_FALSE(hit->downloaded());

  auto bad = cache->GetAsync("not-a-key").get();
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
}

struct Corruption {
  const char* name;
  bool reopen;  // as a restarted process would see it
  std::function<void(const fs::path& file)> damage;
};

TEST(CacheGet, DamagedLocalFilesAreDetectedAndFetchedAgain) {
  ServerProcess server(0);
  const PublishedResult published = PublishResult(server, kSmallMaps, 3);
  const Corruption cases[] = {
      {"byte flipped in place, seen by a new process", true,
       [](const fs::path& f) {
         std::fstream io(f, std::ios::in | std::ios::out | std::ios::binary);
         io.seekg(1000);
         char c;
         io.get(c);
         io.seekp(1000);
         io.put(static_cast<char>(c ^ 0x5a));
       }},
      {"truncated", false, [](const fs::path& f) { fs::resize_file(f, fs::file_size(f) / 2); }},
      {"replaced by other bytes of the same size", false,
       [](const fs::path& f) {
         const auto size = fs::file_size(f);
         fs::remove(f);
         std::ofstream(f, std::ios::binary) << testing::RandomBytes(static_cast<int64_t>(size), 99);
       }},
      {"deleted", false, [](const fs::path& f) { fs::remove(f); }},
  };
  for (const Corruption& c : cases) {
    const fs::path dir = testing::NewTempDir("cache_corrupt");
    auto cache = OpenCache(Options(server.address(), dir));
    {
      auto first = cache->Get(published.key);
      ASSERT_TRUE(first.ok()) << c.name << ": " << first.status();
      c.damage(first->map("albedo_alpha")->path);
    }
    if (c.reopen) cache = OpenCache(Options(server.address(), dir));
    auto again = cache->Get(published.key);
    ASSERT_TRUE(again.ok()) << c.name << ": " << again.status();
    EXPECT_TRUE(again->downloaded()) << c.name;
    ExpectBytes(*again, published, c.name);
    EXPECT_EQ(cache->Stats().corrupt_entries, 1) << c.name << ": every damage is counted, a deleted file too";
  }
  // An entry whose record (.entry) cannot be read, found by a new process.
  const fs::path dir = testing::NewTempDir("cache_corrupt_record");
  {
    auto cache = OpenCache(Options(server.address(), dir));
    ASSERT_TRUE(cache->Get(published.key).ok());
  }
  for (const auto& f : fs::recursive_directory_iterator(dir / "entries")) {
    if (f.path().filename() == ".entry") std::ofstream(f.path(), std::ios::trunc) << "{ not json";
  }
  auto cache = OpenCache(Options(server.address(), dir));
  auto again = cache->Get(published.key);
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_TRUE(again->downloaded());
  EXPECT_EQ(cache->Stats().corrupt_entries, 1) << "an unreadable record is damage too";
}

// The warning a game's tester saw on stderr ("cache: <key> is damaged
// (...); fetching it again") goes to the log handler (impostor/log.h) with
// its level, and not to stderr.
TEST(CacheGet, DamagedFileWarningGoesToTheLogHandlerNotStderr) {
  ServerProcess server(0);
  const PublishedResult published = PublishResult(server, kSmallMaps, 3);
  auto cache = OpenCache(Options(server.address(), testing::NewTempDir("cache_log_handler")));
  {
    auto first = cache->Get(published.key);
    ASSERT_TRUE(first.ok()) << first.status();
    const fs::path albedo = first->map("albedo_alpha")->path;
    fs::resize_file(albedo, fs::file_size(albedo) / 2);
  }
  std::mutex mu;
  std::vector<std::pair<sdk::LogLevel, std::string>> lines;
  sdk::SetLogHandler([&](sdk::LogLevel level, std::string_view message) {
    std::lock_guard lock(mu);
    lines.emplace_back(level, std::string(message));
  });
  ::testing::internal::CaptureStderr();
  auto again = cache->Get(published.key);
  const std::string err = ::testing::internal::GetCapturedStderr();
  sdk::SetLogHandler(nullptr);
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_TRUE(again->downloaded());
  std::lock_guard lock(mu);
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0].first, sdk::LogLevel::kWarning);
  EXPECT_EQ(lines[0].second.rfind("cache: " + published.key + " is damaged (", 0), 0u) << lines[0].second;
  EXPECT_NE(lines[0].second.find("; fetching it again"), std::string::npos) << lines[0].second;
  EXPECT_EQ(err.find("is damaged"), std::string::npos) << err;
}

TEST(CacheGet, SixtyFourThreadsGettingOneKeyShareOneDownload) {
  ServerProcess server(0);
  const PublishedResult published = PublishResult(server, {4 << 20, 4 << 20, 2 << 20}, 4);
  RpcCounter rpcs;
  auto cache = OpenCache(Options(server.address(), testing::NewTempDir("cache_64")), &rpcs);
  constexpr int kThreads = 64;
  std::latch start(kThreads);
  std::vector<absl::StatusOr<CachedResult>> results(kThreads);
  std::vector<std::thread> threads;
  for (int i = 0; i < kThreads; ++i) {
    threads.emplace_back([&, i] {
      start.arrive_and_wait();
      results[i] = cache->Get(published.key);
    });
  }
  for (auto& t : threads) t.join();
  for (int i = 0; i < kThreads; ++i) {
    ASSERT_TRUE(results[i].ok()) << "thread " << i << ": " << results[i].status();
    EXPECT_EQ(results[i]->dir(), results[0]->dir());
  }
  ExpectBytes(*results[0], published, "shared download");
  EXPECT_EQ(rpcs.Count(kGetResult), 1);
  EXPECT_EQ(rpcs.Count(kReadBlob), 3) << "the three maps over 1 MiB stream";
  EXPECT_EQ(rpcs.Count(kBatchRead), 1) << "manifest.json";
  EXPECT_EQ(cache->Stats().downloads, 1);
}

TEST(CacheGet, InterruptedDownloadResumesFromItsOffsetAfterServerRestart) {
  const fs::path data = testing::NewTempDir("cache_resume_server");
  auto server = std::make_unique<ServerProcess>(0, data, "127.0.0.1:0");
  const std::string address = server->address();
  const PublishedResult published = PublishResult(*server, {40 << 20, 64 << 10, 64 << 10}, 5);
  const std::string& big = published.files.at("albedo_alpha.png");
  const std::string big_hash = testing::DigestOf(big).hash();
  const fs::path dir = testing::NewTempDir("cache_resume");

  // First run: the server dies once 1 MiB of the big map has arrived. The
  // map is far larger than what socket buffers and HTTP/2 windows can hold
  // in flight, so the transfer is cut off midway.
  {
    std::atomic<bool> killed{false};
    sdk::DownloadHooks hooks;
    hooks.on_blob_bytes = [&](const std::string& hash, int64_t received) {
      if (hash == big_hash && received >= (1 << 20) && !killed.exchange(true)) {
        ::kill(server->process().pid(), SIGKILL);
      }
    };
    auto cache = OpenCache(Options(address, dir), nullptr, hooks);
    auto got = cache->Get(published.key);
    ASSERT_TRUE(killed.load());
    ASSERT_FALSE(got.ok());
    EXPECT_EQ(got.status().code(), absl::StatusCode::kUnavailable) << got.status();
  }
  int64_t kept = 0;
  for (const auto& entry : fs::directory_iterator(dir / "partial")) kept += fs::file_size(entry.path());
  ASSERT_GT(kept, 0);
  ASSERT_LT(kept, static_cast<int64_t>(big.size()));
  EXPECT_EQ(ReadFileBytes(*fs::directory_iterator(dir / "partial")), big.substr(0, kept))
      << "the partial file holds the first bytes";

  // Second run, as a restarted game against the restarted server.
  server.reset();
  server = std::make_unique<ServerProcess>(0, data, address);
  std::map<std::string, int64_t> starts;
  sdk::DownloadHooks hooks;
  hooks.on_blob_start = [&](const std::string& hash, int64_t offset) { starts.emplace(hash, offset); };
  auto cache = OpenCache(Options(address, dir), nullptr, hooks);
  auto got = cache->Get(published.key);
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_EQ(starts.at(big_hash), kept) << "resumed at the bytes already on disk, not at zero";
  const sdk::CacheStats stats = cache->Stats();
  EXPECT_EQ(stats.bytes_resumed, kept);
  EXPECT_EQ(stats.bytes_downloaded, published.total_bytes - kept);
  ExpectBytes(*got, published, "resumed");
  EXPECT_TRUE(fs::is_empty(dir / "partial")) << "installed partials are cleaned up";
}

TEST(CacheEviction, StaysUnderItsCapAndNeverRemovesAResultInUse) {
  ServerProcess server(0);
  std::vector<PublishedResult> results;
  for (uint32_t i = 0; i < 4; ++i) results.push_back(PublishResult(server, {256 << 10, 128 << 10, 64 << 10}, 10 + i));
  const int64_t each = results[0].total_bytes;
  const fs::path dir = testing::NewTempDir("cache_evict");
  sdk::CacheOptions options = Options(server.address(), dir);
  options.max_bytes = each * 5 / 2;  // room for two
  auto cache = OpenCache(options);

  auto a = cache->Get(results[0].key);  // held throughout
  ASSERT_TRUE(a.ok()) << a.status();
  ASSERT_TRUE(cache->Get(results[1].key).ok());  // released at once
  ASSERT_TRUE(cache->Get(results[2].key).ok());  // over the cap: B goes, A is in use
  EXPECT_TRUE(fs::exists(a->dir())) << "a result with a live handle was evicted";
  ExpectBytes(*a, results[0], "pinned A");
  EXPECT_FALSE(fs::exists(dir / "entries" / results[1].key)) << "the least recently used free result stays";
  EXPECT_LE(cache->Stats().bytes, options.max_bytes);

  // Another process sharing the directory respects the pin too.
  sdk::CacheOptions greedy = options;
  greedy.max_bytes = 0;
  auto other = OpenCache(greedy);
  auto gc = other->CollectGarbage();
  ASSERT_TRUE(gc.ok()) << gc.status();
  EXPECT_TRUE(fs::exists(a->dir())) << "evicted by another process while in use";
  other.reset();

  // Once released, A is the first to go.
  const fs::path a_dir = a->dir();
  a = CachedResult();
  ASSERT_TRUE(cache->Get(results[3].key).ok());
  EXPECT_FALSE(fs::exists(a_dir));
  EXPECT_LE(cache->Stats().bytes, options.max_bytes);
  EXPECT_GE(cache->Stats().evicted_entries, 2);
}

TEST(CacheOffline, CachedKeySucceedsAndMissingKeyFailsFastWithUnavailable) {
  auto server = std::make_unique<ServerProcess>(0);
  const PublishedResult published = PublishResult(*server, kSmallMaps, 20);
  const std::string address = server->address();
  const fs::path dir = testing::NewTempDir("cache_offline");
  auto online = OpenCache(Options(address, dir));
  ASSERT_TRUE(online->Get(published.key).ok());
  server.reset();  // nobody listens there now
  const std::string missing(64, 'a');

  // The same cache, whose channel had connected, and a fresh one.
  RpcCounter rpcs;
  auto fresh = OpenCache(Options(address, dir), &rpcs);
  for (Cache* cache : {online.get(), fresh.get()}) {
    auto hit = cache->Get(published.key);
    ASSERT_TRUE(hit.ok()) << hit.status();
    ExpectBytes(*hit, published, "offline hit");
    auto miss = cache->Get(missing);
    EXPECT_EQ(miss.status().code(), absl::StatusCode::kUnavailable) << miss.status();
  }
  // Failing fast is a bounded number of tries (options.max_attempts = 2;
  // none leave while the channel cannot connect), not a figure in seconds
  // (how long it takes is bench/ material).
  EXPECT_LE(rpcs.Count(kGetResult), 2) << "offline, a miss must not retry beyond max_attempts";
  EXPECT_EQ(rpcs.Count(kReadBlob), 0);
  EXPECT_EQ(rpcs.Count(kBatchRead), 0);
}

TEST(CacheLookup, FindsTheKeyOfABakedMeshWithoutBaking) {
  ServerProcess server(0);
  const fs::path box = testing::AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb";
  auto client = sdk::Client::Connect({.server = server.address()});
  ASSERT_TRUE(client.ok()) << client.status();
  const sdk::BakeSettings settings = Settings("octahedral", 3, 64);
  auto submitted = (*client)->SubmitBake(box, settings);
  ASSERT_TRUE(submitted.ok()) << submitted.status();
  const PublishedResult published = testing::CompleteNextJob(server, kSmallMaps, 30);
  ASSERT_EQ(published.key, submitted->cache_key);

  auto cache = OpenCache(Options(server.address(), testing::NewTempDir("cache_lookup")));
  auto hit = cache->Lookup(box, settings);
  ASSERT_TRUE(hit.ok()) << hit.status();
  EXPECT_TRUE(hit->found);
  EXPECT_EQ(hit->cache_key, submitted->cache_key);
  auto got = cache->Get(hit->cache_key);
  ASSERT_TRUE(got.ok()) << got.status();
  ExpectBytes(*got, published, "looked up");

  auto miss = cache->Lookup(box, Settings("hemi-octahedral", 2, 64));
  ASSERT_TRUE(miss.ok()) << miss.status();
  EXPECT_FALSE(miss->found);
  EXPECT_EQ(miss->cache_key.size(), 64u);
  EXPECT_NE(miss->cache_key, hit->cache_key);

  EXPECT_EQ(cache->Lookup("/nonexistent/model.glb", settings).status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(cache->Lookup(box, Settings("spherical", 0, 0)).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(CachePrefetch, DownloadsInTheBackgroundAndReportsEachKey) {
  ServerProcess server(0);
  std::vector<std::string> keys;
  std::vector<PublishedResult> results;
  for (uint32_t i = 0; i < 5; ++i) {
    results.push_back(PublishResult(server, {64 << 10, 64 << 10, 64 << 10}, 40 + i));
    keys.push_back(results.back().key);
  }
  keys.push_back(std::string(64, 'b'));  // never baked
  keys.push_back("bad key");
  RpcCounter rpcs;
  sdk::CacheOptions options = Options(server.address(), testing::NewTempDir("cache_prefetch"));
  options.max_parallel_prefetches = 2;
  auto cache = OpenCache(options, &rpcs);

  std::mutex mu;
  std::map<std::string, absl::StatusCode> outcomes;
  std::latch all(static_cast<ptrdiff_t>(keys.size()));
  cache->Prefetch(keys, [&](const std::string& key, const absl::Status& status) {
    {
      std::lock_guard lock(mu);
      outcomes[key] = status.code();
    }
    all.count_down();
  });
  all.wait();
  for (const PublishedResult& r : results) EXPECT_EQ(outcomes[r.key], absl::StatusCode::kOk) << r.key;
  EXPECT_EQ(outcomes[std::string(64, 'b')], absl::StatusCode::kNotFound);
  EXPECT_EQ(outcomes["bad key"], absl::StatusCode::kInvalidArgument);

  const int reads = rpcs.Count(kReadBlob) + rpcs.Count(kBatchRead);
  EXPECT_EQ(rpcs.Count(kBatchRead), 5) << "each result's small files in one call";
  for (const PublishedResult& r : results) {
    auto got = cache->Get(r.key);
    ASSERT_TRUE(got.ok()) << got.status();
    EXPECT_FALSE(got->downloaded());
  }
  EXPECT_EQ(rpcs.Count(kReadBlob) + rpcs.Count(kBatchRead), reads) << "prefetched keys are hits";
}

TEST(CacheGet, NotFoundAndBadKeysSayWhy) {
  ServerProcess server(0);
  auto cache = OpenCache(Options(server.address(), testing::NewTempDir("cache_bad_keys")));
  struct Case {
    const char* name;
    std::string key;
    absl::StatusCode code;
  };
  const Case cases[] = {
      {"empty", "", absl::StatusCode::kInvalidArgument},
      {"upper case hex", std::string(64, 'A'), absl::StatusCode::kInvalidArgument},
      {"63 characters", std::string(63, 'a'), absl::StatusCode::kInvalidArgument},
      {"path escape", "../" + std::string(61, 'a'), absl::StatusCode::kInvalidArgument},
      {"well-formed but never baked", std::string(64, 'c'), absl::StatusCode::kNotFound},
  };
  for (const Case& c : cases) {
    EXPECT_EQ(cache->Get(c.key).status().code(), c.code) << c.name;
  }
}

TEST(CacheOpen, BadOptionsAreNamed) {
  struct Case {
    const char* name;
    std::function<void(sdk::CacheOptions&)> change;
    const char* field;
  };
  const Case cases[] = {
      {"no dir", [](auto& o) { o.dir.clear(); }, "dir"},
      {"no server", [](auto& o) { o.server.clear(); }, "server"},
      {"negative cap", [](auto& o) { o.max_bytes = -1; }, "max_bytes"},
      {"no download threads", [](auto& o) { o.max_parallel_downloads = 0; }, "max_parallel_downloads"},
      {"more prefetches than downloads", [](auto& o) { o.max_parallel_prefetches = 30; }, "max_parallel_prefetches"},
      {"no io threads", [](auto& o) { o.io_threads = 0; }, "io_threads"},
      {"zero timeout", [](auto& o) { o.rpc_timeout_seconds = 0; }, "rpc_timeout_seconds"},
      {"no attempts", [](auto& o) { o.max_attempts = 0; }, "max_attempts"},
      {"negative outage", [](auto& o) { o.max_outage_seconds = -1; }, "max_outage_seconds"},
      {"outage over a day", [](auto& o) { o.max_outage_seconds = 1e9; }, "max_outage_seconds"},
      {"outage NaN", [](auto& o) { o.max_outage_seconds = std::nan(""); }, "max_outage_seconds"},
      {"keepalive zero", [](auto& o) { o.keepalive_seconds = 0; }, "CacheOptions.keepalive_seconds: 0 is out of range 1..7200"},
  };
  for (const Case& c : cases) {
    sdk::CacheOptions o;
    o.dir = testing::NewTempDir("cache_bad_options");
    c.change(o);
    auto cache = Cache::Open(o);
    ASSERT_FALSE(cache.ok()) << c.name;
    EXPECT_EQ(cache.status().code(), absl::StatusCode::kInvalidArgument) << c.name;
    EXPECT_NE(cache.status().message().find(c.field), std::string_view::npos) << c.name << ": " << cache.status();
  }
  // A directory that is not a cache of this format is refused, not wiped.
  const fs::path foreign = testing::NewTempDir("cache_foreign");
  std::ofstream(foreign / "FORMAT") << "something else\n";
  auto cache = Cache::Open({.dir = foreign});
  EXPECT_EQ(cache.status().code(), absl::StatusCode::kInternal) << cache.status();
}

}  // namespace
}  // namespace impostor
