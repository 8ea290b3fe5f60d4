// One cache directory shared by several Cache objects and processes at once
// (cache.h: "Several Cache objects, in this process or others, may share
// it"), against a real impostor-server: concurrent installs of one key and
// of keys that share blobs, `impostor cache` commands and collectors beside
// a download, a stopped holder of a partial file, eviction right after an
// install, the directory deleted under a running cache, what the counters
// say when another cache did the download, and closing a cache from its own
// callback. Interleavings are forced with the download hooks
// (cache_testing.h), never with sleeps.
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <future>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "client/cache/cache_testing.h"
#include "impostor/cache.h"
#include "impostor/impostor_c.h"
#include "tests/support/published_result.h"
#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;
using sdk::Cache;
using sdk::CachedResult;

// How long a step the test waits for may take before the test fails
// instead of hanging (generous: a loaded 2-core machine).
constexpr std::chrono::seconds kStep{60};

// A one-shot signal between a hook (on a cache thread) and the test.
class Gate {
 public:
  void Open() {
    std::lock_guard lock(mu_);
    open_ = true;
    cv_.notify_all();
  }
  bool Wait(std::chrono::seconds timeout = kStep) {
    std::unique_lock lock(mu_);
    return cv_.wait_for(lock, timeout, [&] { return open_; });
  }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  bool open_ = false;
};

sdk::CacheOptions Options(const std::string& server, const fs::path& dir) {
  sdk::CacheOptions o;
  o.server = server;
  o.dir = dir;
  o.max_attempts = 2;
  o.max_outage_seconds = 0;
  return o;
}

std::unique_ptr<Cache> OpenCache(const sdk::CacheOptions& options, sdk::DownloadHooks download = {}) {
  sdk::CacheTestHooks hooks;
  hooks.download = std::move(download);
  auto cache = sdk::CacheFactory::Open(options, hooks);
  EXPECT_TRUE(cache.ok()) << cache.status();
  return cache.ok() ? std::move(*cache) : nullptr;
}

void ExpectBytes(const CachedResult& result, const PublishedResult& published, const std::string& context) {
  ASSERT_TRUE(result.valid()) << context;
  ASSERT_EQ(result.files().size(), published.files.size()) << context;
  for (const sdk::CachedFile& f : result.files()) {
    const std::string name = f.path.filename().string();
    ASSERT_TRUE(published.files.contains(name)) << context << ": " << name;
    EXPECT_EQ(ReadFileBytes(f.path), published.files.at(name)) << context << ": " << name;
  }
}

std::string HashOf(const PublishedResult& r, const std::string& file) { return DigestOf(r.files.at(file)).hash(); }

fs::path PartialPath(const fs::path& dir, const std::string& bytes) {
  const v1::Digest d = DigestOf(bytes);
  return dir / "partial" / (d.hash() + "-" + std::to_string(d.size_bytes()) + ".part");
}

std::vector<std::string> Names(const fs::path& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    names.push_back(it->path().filename().string());
  }
  return names;
}

// The leftovers a finished set of Gets must not leave: partial files and
// staging directories.
void ExpectNothingLeftBehind(const fs::path& dir, const std::string& context) {
  EXPECT_EQ(Names(dir / "partial"), std::vector<std::string>{}) << context << ": partial files left behind";
  EXPECT_EQ(Names(dir / "staging"), std::vector<std::string>{}) << context << ": staging directories left behind";
}

// Another process's download of a partial file, stopped (SIGSTOP, a
// debugger) while it holds the file's lock: `bytes` on disk, lock held
// until Release.
class StoppedHolder {
 public:
  StoppedHolder(const fs::path& path, const std::string& bytes) {
    fs::create_directories(path.parent_path());
    fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    EXPECT_GE(fd_, 0) << path;
    EXPECT_EQ(::write(fd_, bytes.data(), bytes.size()), static_cast<ssize_t>(bytes.size()));
    EXPECT_EQ(::flock(fd_, LOCK_EX | LOCK_NB), 0) << path;
  }
  ~StoppedHolder() { Release(); }
  void Release() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

 private:
  int fd_ = -1;
};

const std::vector<int64_t> kMaps = {512 << 10, 256 << 10, 128 << 10};

// Defect: a Get that had checked a shared partial file found it deleted by
// the install of another key that shares it ("cannot link ... No such file
// or directory"), and left its own partial files behind.
TEST(CacheSharedDir, KeysSharingBlobsFetchedAtOnceBothInstallAndLeaveNothingBehind) {
  ServerProcess server(0);
  const PublishedResult a = PublishResult(server, kMaps, 70, false, /*map_seed=*/77);
  const PublishedResult b = PublishResult(server, kMaps, 71, false, /*map_seed=*/77);
  ASSERT_NE(a.key, b.key);
  ASSERT_EQ(a.files.at("albedo_alpha.png"), b.files.at("albedo_alpha.png"));
  const fs::path dir = NewTempDir("cache_shared_blobs");

  // B fetches the three shared maps, then stops before its own manifest
  // until A has fetched and installed its result from those very maps.
  Gate b_paused, a_done;
  sdk::DownloadHooks b_hooks;
  b_hooks.on_blob_start = [&, manifest = HashOf(b, "manifest.json")](const std::string& hash, int64_t) {
    if (hash != manifest) return;
    b_paused.Open();
    EXPECT_TRUE(a_done.Wait());
  };
  auto cache_a = OpenCache(Options(server.address(), dir));
  auto cache_b = OpenCache(Options(server.address(), dir), b_hooks);
  absl::StatusOr<CachedResult> got_b = absl::UnknownError("not run");
  std::thread b_thread([&] { got_b = cache_b->Get(b.key); });
  ASSERT_TRUE(b_paused.Wait()) << "B never reached its manifest";
  absl::StatusOr<CachedResult> got_a = cache_a->Get(a.key);
  a_done.Open();
  b_thread.join();

  ASSERT_TRUE(got_a.ok()) << got_a.status();
  ASSERT_TRUE(got_b.ok()) << got_b.status();
  ExpectBytes(*got_a, a, "A");
  ExpectBytes(*got_b, b, "B");
  ExpectNothingLeftBehind(dir, "after both installs");

  // What each transferred: B everything, A only its manifest (the maps were
  // whole on disk already: neither fetched nor "resumed" by A).
  const sdk::CacheStats stats_a = cache_a->Stats(), stats_b = cache_b->Stats();
  EXPECT_EQ(stats_b.bytes_downloaded, b.total_bytes);
  EXPECT_EQ(stats_b.bytes_resumed, 0);
  EXPECT_EQ(stats_a.bytes_downloaded, static_cast<int64_t>(a.files.at("manifest.json").size()));
  EXPECT_EQ(stats_a.bytes_resumed, 0) << "whole partials another download made are not resumed bytes";
  EXPECT_TRUE(got_a->downloaded()) << "A fetched its manifest";
}

// Defect: a Get that waited for another cache's download of the same key
// counted it as its own (downloads=1, every byte "resumed",
// downloaded()=true), or failed linking the partial files the winner had
// deleted.
TEST(CacheSharedDir, AGetServedByAnotherCachesDownloadCountsNoTransferOfItsOwn) {
  ServerProcess server(0);
  const PublishedResult published = PublishResult(server, kMaps, 72);
  const fs::path dir = NewTempDir("cache_waiter_stats");

  // A holds its manifest's partial file until B waits for it.
  Gate a_paused, b_waiting;
  sdk::DownloadHooks a_hooks, b_hooks;
  a_hooks.on_blob_start = [&, manifest = HashOf(published, "manifest.json")](const std::string& hash, int64_t) {
    if (hash != manifest) return;
    a_paused.Open();
    EXPECT_TRUE(b_waiting.Wait());
  };
  b_hooks.on_partial_wait = [&](const std::string&) { b_waiting.Open(); };
  b_hooks.partial_stall_seconds = 3600;  // A is slow, not stopped: B must wait for it
  auto cache_a = OpenCache(Options(server.address(), dir), a_hooks);
  auto cache_b = OpenCache(Options(server.address(), dir), b_hooks);
  absl::StatusOr<CachedResult> got_a = absl::UnknownError("not run");
  std::thread a_thread([&] { got_a = cache_a->Get(published.key); });
  ASSERT_TRUE(a_paused.Wait()) << "A never reached its manifest";
  absl::StatusOr<CachedResult> got_b = cache_b->Get(published.key);
  a_thread.join();

  ASSERT_TRUE(got_a.ok()) << got_a.status();
  ASSERT_TRUE(got_b.ok()) << got_b.status();
  ExpectBytes(*got_a, published, "A");
  ExpectBytes(*got_b, published, "B");
  EXPECT_EQ(got_a->dir(), got_b->dir());
  ExpectNothingLeftBehind(dir, "after both Gets");

  const sdk::CacheStats stats_a = cache_a->Stats(), stats_b = cache_b->Stats();
  EXPECT_TRUE(got_a->downloaded());
  EXPECT_EQ(stats_a.downloads, 1);
  EXPECT_EQ(stats_a.bytes_downloaded, published.total_bytes);
  EXPECT_EQ(stats_a.bytes_resumed, 0);
  EXPECT_FALSE(got_b->downloaded()) << "B transferred nothing";
  EXPECT_EQ(stats_b.misses, 1);
  EXPECT_EQ(stats_b.downloads, 0);
  EXPECT_EQ(stats_b.bytes_downloaded, 0);
  EXPECT_EQ(stats_b.bytes_resumed, 0);
}

// Defect: 3 processes getting one key at once into an empty directory: a
// quarter of them failed INTERNAL "cannot link" and left partial files.
// Real processes (the CLI, through the same library), several rounds.
TEST(CacheSharedDir, ProcessesGettingOneKeyAtOnceAllSucceedAndLeaveNothingBehind) {
  ServerProcess server(0);
  const PublishedResult published = PublishResult(server, {6 << 20, 4 << 20, 2 << 20}, 73);
  constexpr int kRounds = 3, kProcesses = 4;
  for (int round = 0; round < kRounds; ++round) {
    const fs::path dir = NewTempDir("cache_same_key_processes");
    std::vector<std::unique_ptr<ChildProcess>> getters;
    for (int i = 0; i < kProcesses; ++i) {
      getters.push_back(std::make_unique<ChildProcess>(
          std::vector<std::string>{(BinaryDir() / "impostor").string(), "cache", "get", published.key, "--json",
                                   "--cache-dir", dir.string(), "--server", server.address()},
          ProcessOptions{.name = "cache-get-" + std::to_string(i), .env = {}}));
    }
    int downloaded = 0;
    for (auto& getter : getters) {
      std::string out;
      const int code = getter->Wait(&out);
      EXPECT_EQ(code, 0) << "round " << round << ", " << getter->name() << ": " << getter->Stderr();
      const size_t last = out.rfind("\n{", out.size() >= 2 ? out.size() - 2 : 0);
      const nlohmann::json report = nlohmann::json::parse(out.substr(last == std::string::npos ? 0 : last + 1),
                                                          nullptr, /*allow_exceptions=*/false);
      if (report.is_object() && report.value("downloaded", false)) ++downloaded;
    }
    EXPECT_GE(downloaded, 1) << "round " << round;
    ExpectNothingLeftBehind(dir, "round " + std::to_string(round));
    for (const auto& [name, bytes] : published.files) {
      EXPECT_EQ(ReadFileBytes(dir / "entries" / published.key / name), bytes) << "round " << round << ": " << name;
    }
  }
}

// Defect: `impostor cache ls/gc/get` deleted every unlocked partial file of
// the directory: another process's finished-but-not-installed ones (its Get
// then failed "cannot link") and a killed download's resume data.
TEST(CacheSharedDir, CacheCommandsKeepOtherDownloadsPartialsAndResumeData) {
  ServerProcess server(0);
  const PublishedResult in_flight = PublishResult(server, kMaps, 74);
  const PublishedResult killed = PublishResult(server, kMaps, 75);
  const PublishedResult third = PublishResult(server, {16 << 10, 16 << 10, 16 << 10}, 76);
  const fs::path dir = NewTempDir("cache_cli_partials");

  // A Get that has its maps and is about to fetch its manifest.
  Gate paused, go;
  sdk::DownloadHooks hooks;
  hooks.on_blob_start = [&, manifest = HashOf(in_flight, "manifest.json")](const std::string& hash, int64_t) {
    if (hash != manifest) return;
    paused.Open();
    EXPECT_TRUE(go.Wait());
  };
  auto cache = OpenCache(Options(server.address(), dir), hooks);
  // A killed download's first 100 KiB of another result's map.
  const std::string& killed_map = killed.files.at("albedo_alpha.png");
  constexpr int64_t kKept = 100 << 10;
  const fs::path resume = PartialPath(dir, killed_map);
  std::ofstream(resume, std::ios::binary) << killed_map.substr(0, kKept);

  absl::StatusOr<CachedResult> got = absl::UnknownError("not run");
  std::thread getter([&] { got = cache->Get(in_flight.key); });
  ASSERT_TRUE(paused.Wait());
  const std::string impostor = (BinaryDir() / "impostor").string();
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{impostor, "cache", "ls", "--cache-dir", dir.string()},
        std::vector<std::string>{impostor, "cache", "gc", "--cache-dir", dir.string()},
        std::vector<std::string>{impostor, "cache", "get", third.key, "--cache-dir", dir.string(), "--server",
                                 server.address()}}) {
    const ToolRun run = RunTool(args);
    EXPECT_EQ(run.exit_code, 0) << args[2] << ": " << run.err;
  }
  go.Open();
  getter.join();
  ASSERT_TRUE(got.ok()) << got.status();
  ExpectBytes(*got, in_flight, "the Get beside the commands");

  ASSERT_TRUE(fs::exists(resume)) << "the resume data of a killed download was deleted";
  EXPECT_EQ(static_cast<int64_t>(fs::file_size(resume)), kKept);
  std::vector<int64_t> starts;
  sdk::DownloadHooks resume_hooks;
  resume_hooks.on_blob_start = [&, map = DigestOf(killed_map).hash()](const std::string& hash, int64_t offset) {
    if (hash == map) starts.push_back(offset);
  };
  auto resumer = OpenCache(Options(server.address(), dir), resume_hooks);
  auto resumed = resumer->Get(killed.key);
  ASSERT_TRUE(resumed.ok()) << resumed.status();
  ExpectBytes(*resumed, killed, "resumed");
  EXPECT_EQ(starts, std::vector<int64_t>{kKept});
  EXPECT_EQ(resumer->Stats().bytes_resumed, kKept);
}

// Defect: a Cache opened with partial_max_age_seconds = 0, or its
// CollectGarbage, deleted the finished partial files another cache was
// about to install.
TEST(CacheSharedDir, ACollectorWithNoPartialAgeNeverBreaksAnotherCachesInstall) {
  ServerProcess server(0);
  const PublishedResult published = PublishResult(server, kMaps, 78);
  const fs::path dir = NewTempDir("cache_age_zero_collector");
  Gate paused, go;
  sdk::DownloadHooks hooks;
  hooks.on_blob_start = [&, manifest = HashOf(published, "manifest.json")](const std::string& hash, int64_t) {
    if (hash != manifest) return;
    paused.Open();
    EXPECT_TRUE(go.Wait());
  };
  auto cache = OpenCache(Options(server.address(), dir), hooks);
  absl::StatusOr<CachedResult> got = absl::UnknownError("not run");
  std::thread getter([&] { got = cache->Get(published.key); });
  ASSERT_TRUE(paused.Wait());
  {
    sdk::CacheOptions greedy = Options(server.address(), dir);
    greedy.partial_max_age_seconds = 0;
    greedy.max_bytes = 0;
    auto collector = OpenCache(greedy);
    ASSERT_NE(collector, nullptr);
    auto gc = collector->CollectGarbage(0);
    EXPECT_TRUE(gc.ok()) << gc.status();
  }
  go.Open();
  getter.join();
  ASSERT_TRUE(got.ok()) << got.status();
  ExpectBytes(*got, published, "installed beside a collector");
  ExpectNothingLeftBehind(dir, "after the install");
}

// Garbage collection beside a long install: the install's staging directory
// (which now holds the blobs it has fetched so far) is never taken, however
// old it looks; a killed install's leftover is.
TEST(CacheSharedDir, CollectorsTakeKilledInstallsStagingButNeverARunningOnes) {
  ServerProcess server(0);
  const PublishedResult published = PublishResult(server, kMaps, 86);
  const fs::path dir = NewTempDir("cache_staging_collector");
  Gate paused, go;
  sdk::DownloadHooks hooks;
  hooks.on_blob_start = [&, manifest = HashOf(published, "manifest.json")](const std::string& hash, int64_t) {
    if (hash != manifest) return;
    paused.Open();
    EXPECT_TRUE(go.Wait());
  };
  auto cache = OpenCache(Options(server.address(), dir), hooks);
  absl::StatusOr<CachedResult> got = absl::UnknownError("not run");
  std::thread getter([&] { got = cache->Get(published.key); });
  ASSERT_TRUE(paused.Wait());
  // Both look a day old: the running install's, and a killed one's.
  const fs::path leftover = dir / "staging" / (std::string(64, 'f') + ".AbCdEf");
  fs::create_directory(leftover);
  std::ofstream(leftover / "albedo_alpha.png") << "bytes a killed install had linked";
  const auto day_ago = fs::file_time_type::clock::now() - std::chrono::hours(24);
  std::vector<std::string> staged = Names(dir / "staging");
  for (const std::string& name : staged) fs::last_write_time(dir / "staging" / name, day_ago);
  ASSERT_EQ(staged.size(), 2u);
  {
    sdk::CacheOptions greedy = Options(server.address(), dir);
    greedy.partial_max_age_seconds = 0;
    auto collector = OpenCache(greedy);
    ASSERT_NE(collector, nullptr);
    auto gc = collector->CollectGarbage();
    EXPECT_TRUE(gc.ok()) << gc.status();
  }
  EXPECT_FALSE(fs::exists(leftover)) << "a killed install's staging directory was kept";
  EXPECT_EQ(Names(dir / "staging").size(), 1u) << "the running install's staging directory was taken";
  go.Open();
  getter.join();
  ASSERT_TRUE(got.ok()) << got.status();
  ExpectBytes(*got, published, "installed beside a collector");
  ExpectNothingLeftBehind(dir, "after the install");
}

// Defect: a process stopped while holding a partial file's lock blocked
// every other Get of that key for as long as it stayed stopped.
TEST(CacheSharedDir, AStoppedHolderOfAPartialDelaysAGetOnlyBriefly) {
  ServerProcess server(0);
  const PublishedResult published = PublishResult(server, kMaps, 79);
  const fs::path dir = NewTempDir("cache_stopped_holder");
  const std::string& albedo = published.files.at("albedo_alpha.png");
  const fs::path held_path = PartialPath(dir, albedo);
  StoppedHolder holder(held_path, albedo.substr(0, 1000));

  int waits = 0;
  sdk::DownloadHooks hooks;
  hooks.on_partial_wait = [&](const std::string&) { ++waits; };
  hooks.partial_stall_seconds = 0.5;  // no progress for this long: stop waiting
  auto cache = OpenCache(Options(server.address(), dir), hooks);
  std::future<absl::StatusOr<CachedResult>> future = cache->GetAsync(published.key);
  const bool ready = future.wait_for(kStep) == std::future_status::ready;
  holder.Release();  // lets a blocked Get finish, so the test ends either way
  ASSERT_TRUE(ready) << "the Get waited for the stopped holder";
  absl::StatusOr<CachedResult> got = future.get();
  ASSERT_TRUE(got.ok()) << got.status();
  ExpectBytes(*got, published, "fetched around the stopped holder");
  EXPECT_EQ(waits, 1);
  EXPECT_EQ(cache->Stats().bytes_downloaded, published.total_bytes);
  EXPECT_EQ(ReadFileBytes(held_path), albedo.substr(0, 1000)) << "the holder's partial file is its own";
}

// Defect: destroying a cache whose Get waited for a stopped holder blocked
// until the holder went on, and the Get's callback then got OK.
TEST(CacheSharedDir, DestroyingTheCacheCancelsAGetWaitingForAStoppedHolder) {
  ServerProcess server(0);
  const PublishedResult published = PublishResult(server, kMaps, 80);
  const fs::path dir = NewTempDir("cache_stopped_holder_close");
  StoppedHolder holder(PartialPath(dir, published.files.at("albedo_alpha.png")), "");

  Gate waiting, called, destroyed;
  sdk::DownloadHooks hooks;
  hooks.on_partial_wait = [&](const std::string&) { waiting.Open(); };
  hooks.partial_stall_seconds = 3600;  // the holder is waited for: only destruction ends it
  auto cache = OpenCache(Options(server.address(), dir), hooks);
  absl::Status status = absl::UnknownError("no callback");
  cache->GetAsync(published.key, [&](absl::StatusOr<CachedResult> r) {
    status = r.status();
    called.Open();
  });
  ASSERT_TRUE(waiting.Wait()) << "the Get never waited for the held partial";
  std::thread destroyer([&] {
    cache.reset();
    destroyed.Open();
  });
  const bool prompt = destroyed.Wait(std::chrono::seconds(20));
  holder.Release();  // lets a blocked destruction finish, so the test ends either way
  destroyer.join();
  EXPECT_TRUE(prompt) << "destroying the cache waited for the stopped holder";
  ASSERT_TRUE(called.Wait());
  EXPECT_EQ(status.code(), absl::StatusCode::kCancelled) << status;
}

// The server goes away while a Get downloads, with an outage budget of
// minutes: destroying the cache ends the Get at once with CANCELLED. (It used
// to wait out the retry backoff and the outage budget: 29 s, UNAVAILABLE.)
TEST(CacheSharedDir, DestroyingTheCacheCancelsAGetRidingOutAnOutage) {
  ServerProcess server(0);
  // One map far larger than a batch read takes (client/transfer/blob_batch.h)
  // and than the stream's receive window (common/net/transfer_window.h): the
  // result's small blobs arrive in one BatchReadBlobs before any blob starts,
  // so a result of small maps would be whole in memory when the server dies.
  const PublishedResult published = PublishResult(server, {int64_t{32} << 20}, 80);
  const fs::path dir = NewTempDir("cache_outage_close");
  Gate started, called, destroyed;
  sdk::DownloadHooks hooks;
  hooks.on_blob_start = [&](const std::string&, int64_t) {
    static std::once_flag once;
    std::call_once(once, [&] {
      server.Kill();
      started.Open();
    });
  };
  sdk::CacheOptions options = Options(server.address(), dir);
  options.max_attempts = 1000;
  options.max_outage_seconds = 300;
  auto cache = OpenCache(options, hooks);
  absl::Status status = absl::UnknownError("no callback");
  cache->GetAsync(published.key, [&](absl::StatusOr<CachedResult> r) {
    status = r.status();
    called.Open();
  });
  ASSERT_TRUE(started.Wait()) << "the download never started";
  const auto start = std::chrono::steady_clock::now();
  std::thread destroyer([&] {
    cache.reset();
    destroyed.Open();
  });
  const bool done = destroyed.Wait(std::chrono::seconds(60));
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  destroyer.join();
  ASSERT_TRUE(done);
  EXPECT_LT(seconds, 10.0) << "destroying the cache waited out the outage";
  ASSERT_TRUE(called.Wait());
  EXPECT_EQ(status.code(), absl::StatusCode::kCancelled) << status;
}

// Defect: another process trimming the cache between an install's rename
// and its pin made the Get fail INTERNAL "vanished right after its install".
TEST(CacheSharedDir, AResultIsPinnedFromTheMomentItIsInstalled) {
  ServerProcess server(0);
  const PublishedResult published = PublishResult(server, kMaps, 81);
  const fs::path dir = NewTempDir("cache_pinned_at_install");
  int64_t evicted = -1;
  sdk::DownloadHooks hooks;
  hooks.on_installed = [&](const std::string&) {
    // Another cache, capped at nothing, opens (and trims) right then.
    sdk::CacheOptions greedy = Options(server.address(), dir);
    greedy.max_bytes = 0;
    auto trimmer = OpenCache(greedy);
    ASSERT_NE(trimmer, nullptr);
    auto gc = trimmer->CollectGarbage(0);
    ASSERT_TRUE(gc.ok()) << gc.status();
    evicted = gc->evicted_entries + trimmer->Stats().evicted_entries;
  };
  auto cache = OpenCache(Options(server.address(), dir), hooks);
  auto got = cache->Get(published.key);
  ASSERT_TRUE(got.ok()) << got.status();
  ExpectBytes(*got, published, "pinned at install");
  EXPECT_EQ(evicted, 0);
}

// Defect: deleting the cache directory under a running game failed every
// later Get INTERNAL until a new Cache was opened.
TEST(CacheSharedDir, ADeletedCacheDirectoryIsRebuiltByTheNextGet) {
  ServerProcess server(0);
  const PublishedResult a = PublishResult(server, kMaps, 82);
  const PublishedResult b = PublishResult(server, kMaps, 83);
  const fs::path dir = NewTempDir("cache_dir_deleted");
  auto cache = OpenCache(Options(server.address(), dir));
  ASSERT_TRUE(cache->Get(a.key).ok());
  fs::remove_all(dir);

  auto again = cache->Get(a.key);
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_TRUE(again->downloaded());
  ExpectBytes(*again, a, "fetched again");
  auto other = cache->Get(b.key);
  ASSERT_TRUE(other.ok()) << other.status();
  ExpectBytes(*other, b, "a miss after the deletion");
  EXPECT_TRUE(fs::exists(dir / "FORMAT"));
  EXPECT_EQ(cache->Stats().entries, 2);

  // Gone again: CollectGarbage rebuilds it and forgets what went with it.
  again = CachedResult();
  other = CachedResult();
  fs::remove_all(dir);
  auto gc = cache->CollectGarbage();
  ASSERT_TRUE(gc.ok()) << gc.status();
  EXPECT_TRUE(fs::is_directory(dir / "partial"));
  EXPECT_TRUE(fs::exists(dir / "FORMAT"));
  EXPECT_EQ(cache->Stats().entries, 0);
  EXPECT_TRUE(cache->List().empty());
}

// Defect: closing the cache from inside a GetAsync callback aborted the
// process (the destructor joined the thread it ran on).
TEST(CacheCallbacks, ClosingTheCacheFromItsOwnCallbackWorks) {
  ServerProcess server(0);
  const PublishedResult published = PublishResult(server, kMaps, 84);
  const fs::path dir = NewTempDir("cache_close_in_callback");

  // A miss: the callback runs on a download thread.
  {
    auto cache = OpenCache(Options(server.address(), dir));
    std::promise<absl::Status> done;
    cache->GetAsync(published.key, [&](absl::StatusOr<CachedResult> r) {
      cache.reset();
      done.set_value(r.status());
    });
    auto future = done.get_future();
    ASSERT_EQ(future.wait_for(kStep), std::future_status::ready);
    EXPECT_TRUE(future.get().ok());
  }
  // A hit, with one I/O thread: the callback runs on it, and a hit queued
  // behind it is still answered, once.
  {
    sdk::CacheOptions options = Options(server.address(), dir);
    options.io_threads = 1;
    auto cache = OpenCache(options);
    Gate second_queued;
    std::promise<absl::Status> first, second;
    cache->GetAsync(published.key, [&](absl::StatusOr<CachedResult> r) {
      EXPECT_TRUE(second_queued.Wait());
      cache.reset();
      first.set_value(r.status());
    });
    cache->GetAsync(published.key, [&](absl::StatusOr<CachedResult> r) { second.set_value(r.status()); });
    second_queued.Open();
    auto first_future = first.get_future(), second_future = second.get_future();
    ASSERT_EQ(first_future.wait_for(kStep), std::future_status::ready);
    ASSERT_EQ(second_future.wait_for(kStep), std::future_status::ready);
    EXPECT_TRUE(first_future.get().ok());
    EXPECT_TRUE(second_future.get().ok());
  }
}

struct CloseInCallback {
  impostor_cache* cache = nullptr;
  std::promise<impostor_status> done;
};

void CloseFromCallback(impostor_status status, impostor_result* result, void* user_data) {
  auto* state = static_cast<CloseInCallback*>(user_data);
  if (result != nullptr) impostor_result_release(result);
  impostor_cache_close(state->cache);
  state->done.set_value(status);
}

TEST(CacheCallbacks, TheCApiClosesTheCacheFromItsGetCallback) {
  ServerProcess server(0);
  const PublishedResult published = PublishResult(server, kMaps, 85);
  const std::string address = server.address(), dir = NewTempDir("c_api_close_in_callback").string();
  impostor_cache_options options;
  impostor_cache_options_init(&options);
  options.server = address.c_str();
  options.dir = dir.c_str();
  CloseInCallback state;
  ASSERT_EQ(impostor_cache_open(&options, &state.cache), IMPOSTOR_OK) << impostor_last_error();
  impostor_cache_get_async(state.cache, published.key.c_str(), CloseFromCallback, &state);
  auto future = state.done.get_future();
  ASSERT_EQ(future.wait_for(kStep), std::future_status::ready);
  EXPECT_EQ(future.get(), IMPOSTOR_OK);
}

}  // namespace
}  // namespace impostor::testing
