#include "tests/delivery/cdn_fleet.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <random>
#include <sstream>

#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "client/cache/cache_testing.h"
#include "tests/support/published_result.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

std::string ReadText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string BlobPathOf(const std::string& sha256) {
  return absl::StrCat("/v1/blobs/sha256/", sha256.substr(0, 2), "/", sha256);
}

double Seconds(Clock::time_point from, Clock::time_point to) {
  return std::chrono::duration<double>(to - from).count();
}

}  // namespace

const ReleaseAsset* PublishedRelease::Find(const std::string& name) const {
  for (const ReleaseAsset& asset : assets) {
    if (asset.name == name) return &asset;
  }
  return nullptr;
}

std::set<std::string> PublishedRelease::BlobPaths(const std::vector<std::string>& names) const {
  std::set<std::string> paths;
  for (const std::string& name : names) {
    if (const ReleaseAsset* asset = Find(name)) {
      for (const ReleaseFile& f : asset->files) paths.insert(f.blob_path);
    }
  }
  return paths;
}

std::map<std::string, int64_t> PublishedRelease::BlobSizes() const {
  std::map<std::string, int64_t> sizes;
  for (const ReleaseAsset& asset : assets) {
    for (const ReleaseFile& f : asset.files) sizes[f.sha256] = f.size_bytes;
  }
  return sizes;
}

absl::StatusOr<PublishedRelease> PublishRelease(ServerProcess& farm, const ReleaseSpec& spec, const fs::path& root) {
  PublishedRelease release;
  release.root = root;
  release.channel = spec.channel;
  std::mt19937 rng(spec.seed);
  const double lo = std::log(static_cast<double>(spec.min_map_bytes));
  const double hi = std::log(static_cast<double>(spec.max_map_bytes));
  auto draw_size = [&] {
    const double u = static_cast<double>(rng()) / 4294967296.0;
    return static_cast<int64_t>(std::exp(lo + u * (hi - lo)));
  };
  std::vector<std::string> pairs;
  std::vector<int64_t> previous_sizes;
  uint32_t previous_map_seed = 0;
  for (int i = 0; i < spec.assets; ++i) {
    std::vector<int64_t> sizes = {draw_size(), draw_size(), draw_size()};
    uint32_t map_seed = spec.seed * 10007u + static_cast<uint32_t>(i) + 1;
    if (spec.shared_every > 0 && i > 0 && i % spec.shared_every == spec.shared_every - 1) {
      // The same maps as the asset before, another manifest (another key).
      sizes = previous_sizes;
      map_seed = previous_map_seed;
    }
    PublishedResult result = PublishResult(farm, sizes, spec.seed * 1000u + static_cast<uint32_t>(i) + 1,
                                           /*one_blob=*/false, map_seed);
    if (result.key.empty()) return absl::InternalError(absl::StrCat("publishing asset ", i, " to the farm failed"));
    char name[64];
    std::snprintf(name, sizeof(name), "fleet/asset_%03d", i);
    ReleaseAsset asset;
    asset.name = name;
    asset.key = result.key;
    asset.published = std::move(result.files);
    release.assets.push_back(std::move(asset));
    pairs.push_back(absl::StrCat(name, "=", release.assets.back().key));
    previous_sizes = sizes;
    previous_map_seed = map_seed;
  }

  std::vector<std::string> argv = {(BinaryDir() / "impostor").string(), "publish"};
  argv.insert(argv.end(), pairs.begin(), pairs.end());
  argv.push_back("--channel=" + spec.channel);
  argv.push_back("--out=" + root.string());
  argv.push_back("--server=" + farm.address());
  const ToolRun run = RunTool(argv);
  if (run.exit_code != 0) {
    return absl::InternalError(absl::StrCat("impostor publish exited ", run.exit_code, ": ", run.err));
  }

  // The channel names the catalog; the catalog lists every asset's files.
  const fs::path channel_file = root / "v1" / "channels" / (spec.channel + ".json");
  nlohmann::json channel = nlohmann::json::parse(ReadText(channel_file), nullptr, /*allow_exceptions=*/false);
  if (channel.is_discarded() || !channel.contains("catalog")) {
    return absl::InternalError(absl::StrCat(channel_file.string(), ": not a channel file"));
  }
  release.catalog_sha256 = channel["catalog"].value("sha256", "");
  if (release.catalog_sha256.size() != 64) {
    return absl::InternalError(absl::StrCat(channel_file.string(), ": no catalog digest"));
  }
  release.catalog_path =
      absl::StrCat("/v1/catalogs/sha256/", release.catalog_sha256.substr(0, 2), "/", release.catalog_sha256);
  const fs::path catalog_file = root / release.catalog_path.substr(1);
  nlohmann::json catalog = nlohmann::json::parse(ReadText(catalog_file), nullptr, /*allow_exceptions=*/false);
  if (catalog.is_discarded() || !catalog.contains("assets")) {
    return absl::InternalError(absl::StrCat(catalog_file.string(), ": not a catalog"));
  }
  for (ReleaseAsset& asset : release.assets) {
    if (!catalog["assets"].contains(asset.name)) {
      return absl::InternalError(absl::StrCat("the catalog does not list ", asset.name));
    }
    const nlohmann::json& entry = catalog["assets"][asset.name];
    if (entry.value("cache_key", "") != asset.key) {
      return absl::InternalError(absl::StrCat("the catalog lists ", asset.name, " under another key"));
    }
    for (const nlohmann::json& f : entry["files"]) {
      ReleaseFile file;
      file.name = f.value("name", "");
      file.sha256 = f.value("sha256", "");
      file.size_bytes = f.value("size_bytes", int64_t{-1});
      file.blob_path = BlobPathOf(file.sha256);
      asset.files.push_back(std::move(file));
    }
  }
  return release;
}

std::vector<std::vector<int>> ZipfDraws(int players, int fetches, int assets, double s, uint32_t seed) {
  std::vector<double> cdf(static_cast<size_t>(assets));
  double total = 0;
  for (int k = 0; k < assets; ++k) {
    total += 1.0 / std::pow(static_cast<double>(k + 1), s);
    cdf[static_cast<size_t>(k)] = total;
  }
  std::mt19937_64 rng(seed);
  std::vector<std::vector<int>> draws(static_cast<size_t>(players));
  for (auto& player : draws) {
    for (int i = 0; i < fetches; ++i) {
      // rng() / 2^64 in [0, 1): the same on every standard library.
      const double u = static_cast<double>(rng() >> 11) * 0x1.0p-53 * total;
      const auto it = std::upper_bound(cdf.begin(), cdf.end(), u);
      player.push_back(static_cast<int>(std::min<ptrdiff_t>(it - cdf.begin(), assets - 1)));
    }
  }
  return draws;
}

FleetRun RunSdkFleet(const FleetOptions& options, const std::vector<std::vector<std::string>>& names,
                     const std::map<std::string, int64_t>& blob_sizes, std::chrono::milliseconds timeout) {
  FleetRun run;
  // Per player: when each blob's download started (hooks run on that
  // player's download threads).
  struct FileClock {
    std::mutex mu;
    std::map<std::string, Clock::time_point> started;
    std::vector<double> seconds;
  };
  std::vector<std::unique_ptr<FileClock>> clocks;
  std::vector<std::unique_ptr<sdk::Cache>> caches;
  for (size_t p = 0; p < names.size(); ++p) {
    sdk::CacheOptions o;
    char dir[32];
    std::snprintf(dir, sizeof(dir), "player_%03zu", p);
    o.dir = options.root / dir;
    o.server = options.server;
    o.mirrors = options.mirrors;
    o.channel = options.channel;
    o.max_parallel_downloads = options.max_parallel_downloads;
    o.max_parallel_prefetches = std::min(o.max_parallel_prefetches, o.max_parallel_downloads);
    o.rpc_timeout_seconds = options.rpc_timeout_seconds;
    o.max_attempts = options.max_attempts;
    o.io_threads = 1;
    sdk::CacheTestHooks hooks;
    auto clock = std::make_unique<FileClock>();
    if (options.time_files) {
      FileClock* c = clock.get();
      hooks.download.on_blob_start = [c](const std::string& sha256, int64_t) {
        std::lock_guard lock(c->mu);
        c->started.emplace(sha256, Clock::now());
      };
      hooks.download.on_blob_bytes = [c, &blob_sizes](const std::string& sha256, int64_t received) {
        auto size = blob_sizes.find(sha256);
        if (size == blob_sizes.end() || received != size->second) return;
        std::lock_guard lock(c->mu);
        auto it = c->started.find(sha256);
        if (it == c->started.end()) return;
        c->seconds.push_back(Seconds(it->second, Clock::now()));
        c->started.erase(it);
      };
    }
    absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = sdk::CacheFactory::Open(o, hooks);
    if (!cache.ok()) {
      run.open_error = std::string(cache.status().message());
      return run;
    }
    caches.push_back(std::move(*cache));
    clocks.push_back(std::move(clock));
  }

  std::mutex mu;
  std::condition_variable all_done;
  size_t pending = 0;
  for (const auto& player : names) pending += player.size();
  run.fetches.resize(pending);
  std::atomic<bool> launched{false};
  std::atomic<int> completed_during_launch{0};
  const Clock::time_point start = Clock::now();
  size_t slot = 0;
  for (size_t p = 0; p < names.size(); ++p) {
    for (const std::string& name : names[p]) {
      FleetFetch& fetch = run.fetches[slot++];
      fetch.player = static_cast<int>(p);
      fetch.name = name;
      caches[p]->GetAsync(name, [&, f = &fetch](absl::StatusOr<sdk::CachedResult> result) {
        const double done = Seconds(start, Clock::now());
        if (!launched.load()) completed_during_launch.fetch_add(1);
        std::lock_guard lock(mu);
        f->result = std::move(result);
        f->done_seconds = done;
        if (--pending == 0) all_done.notify_all();
      });
    }
  }
  launched.store(true);
  run.completed_during_launch = completed_during_launch.load();
  if (options.after_launch) options.after_launch();
  {
    std::unique_lock lock(mu);
    all_done.wait_for(lock, timeout, [&] { return pending == 0; });
  }
  run.wall_seconds = Seconds(start, Clock::now());
  for (const auto& cache : caches) {
    const sdk::CacheStats stats = cache->Stats();
    run.bytes_downloaded += stats.bytes_downloaded;
    run.downloads += stats.downloads;
  }
  // Destroying a cache cancels what is still running (a fetch past the
  // timeout) and waits for its callbacks: after this, nothing writes to run.
  caches.clear();
  for (FleetFetch& fetch : run.fetches) {
    if (fetch.result.status().code() == absl::StatusCode::kUnknown && fetch.result.status().message() == "not done") {
      fetch.result = absl::DeadlineExceededError("the fleet's deadline passed first");
    }
  }
  for (const auto& clock : clocks) {
    run.file_seconds.insert(run.file_seconds.end(), clock->seconds.begin(), clock->seconds.end());
  }
  return run;
}

double Percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const double rank = std::ceil(p / 100.0 * static_cast<double>(values.size()));
  const size_t index = static_cast<size_t>(std::clamp(rank, 1.0, static_cast<double>(values.size()))) - 1;
  return values[index];
}

}  // namespace impostor::testing
