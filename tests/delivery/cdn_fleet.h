// A published release behind nginx, and a fleet of game clients fetching
// from it: what tests/delivery/nginx_cdn_test.cc and bench/fleet_bench.cc
// share (issue 40). The release is real: results are put into a real
// impostor-server without a GPU (tests/support/published_result.h) and
// published with the real `impostor publish`; the fleet is real SDK Cache
// objects, one per player, each with its own cache directory.
//
// Threads: PublishRelease and RunSdkFleet are called from one thread; the
// fleet's own threads are the caches'.
#ifndef IMPOSTOR_TESTS_DELIVERY_CDN_FLEET_H_
#define IMPOSTOR_TESTS_DELIVERY_CDN_FLEET_H_

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "impostor/cache.h"
#include "tests/support/server_process.h"

namespace impostor::testing {

// What PublishRelease bakes (fakes) and publishes.
struct ReleaseSpec {
  int assets = 60;
  // Each map's size is drawn log-uniformly from this range.
  int64_t min_map_bytes = 2 * 1024;
  int64_t max_map_bytes = 200 * 1024;
  uint32_t seed = 40;
  // Every `shared_every`-th asset shares its three map blobs with the asset
  // before it (same map bytes, another manifest); 0: none shared.
  int shared_every = 6;
  std::string channel = "nightly";
};

// One file of an asset as the catalog lists it.
struct ReleaseFile {
  std::string name;    // "albedo_alpha.png", "manifest.json"
  std::string sha256;  // lowercase hex
  int64_t size_bytes = 0;
  std::string blob_path;  // "/v1/blobs/sha256/<hh>/<hex>", as a mirror serves it
};

struct ReleaseAsset {
  std::string name;  // "props/asset_007"
  std::string key;   // the result's cache key
  std::vector<ReleaseFile> files;               // the catalog's list
  std::map<std::string, std::string> published; // file name -> the bytes put into the farm
};

struct PublishedRelease {
  std::filesystem::path root;  // holds v1/
  std::string channel;
  std::string catalog_sha256;
  std::string catalog_path;    // "/v1/catalogs/sha256/<hh>/<hex>"
  std::vector<ReleaseAsset> assets;  // in publish order

  const ReleaseAsset* Find(const std::string& name) const;
  // The distinct blob paths of the named assets.
  std::set<std::string> BlobPaths(const std::vector<std::string>& names) const;
  // sha256 -> size of every blob of the release.
  std::map<std::string, int64_t> BlobSizes() const;
};

// Puts `spec.assets` fake results into `farm`, publishes them all with
// `impostor publish NAME=KEY... --channel --out root --server` and reads
// back the channel and catalog it wrote (with nlohmann::json, not the SDK's
// parser). Errors: INTERNAL naming the step that failed (the tool's stderr
// included).
absl::StatusOr<PublishedRelease> PublishRelease(ServerProcess& farm, const ReleaseSpec& spec,
                                                const std::filesystem::path& root);

// `players` lists of `fetches` indices into [0, assets), each drawn from
// Zipf(s): P(rank k) proportional to 1 / k^s, rank 1 = index 0. Fixed by
// `seed`.
std::vector<std::vector<int>> ZipfDraws(int players, int fetches, int assets, double s, uint32_t seed);

// A fleet: one Cache per player, each in `root`/player_NNN.
struct FleetOptions {
  std::filesystem::path root;
  std::vector<std::string> mirrors;
  std::string channel;
  std::string server;  // "" = mirrors only
  int max_parallel_downloads = 20;
  double rpc_timeout_seconds = 30;
  int max_attempts = 3;
  // Called once every GetAsync is launched, before waiting for them: e.g.
  // to let a paused origin go, so that no fetch can have ended before the
  // last one started.
  std::function<void()> after_launch;
  // Record when each blob download starts and gets its last byte
  // (FleetRun::file_seconds), through the cache's test hooks.
  bool time_files = false;
};

struct FleetFetch {
  int player = 0;
  std::string name;
  absl::StatusOr<sdk::CachedResult> result = absl::UnknownError("not done");
  double done_seconds = 0;  // since the first GetAsync
};

struct FleetRun {
  std::vector<FleetFetch> fetches;  // player-major, in draw order
  double wall_seconds = 0;          // first GetAsync to last callback
  int completed_during_launch = 0;  // callbacks before after_launch was called
  int64_t bytes_downloaded = 0;     // CacheStats::bytes_downloaded, summed
  int64_t downloads = 0;            // CacheStats::downloads, summed
  std::vector<double> file_seconds; // per blob download (time_files)
  std::string open_error;           // a Cache::Open that failed
};

// Opens the caches (not timed), launches every player's GetAsync of its
// names at once, waits for all (bounded by `timeout`: the rest then count
// as DEADLINE_EXCEEDED), closes the caches and returns what each Get gave.
FleetRun RunSdkFleet(const FleetOptions& options, const std::vector<std::vector<std::string>>& names,
                     const std::map<std::string, int64_t>& blob_sizes = {},
                     std::chrono::milliseconds timeout = std::chrono::minutes(5));

// Percentile `p` (0..100) of `values` (nearest rank); 0 for none.
double Percentile(std::vector<double> values, double p);

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_DELIVERY_CDN_FLEET_H_
