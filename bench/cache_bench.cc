// cache_bench: what the game-client cache (impostor/cache.h) costs.
//  - local hit latency: p50/p99 of Cache::Get for a key already on disk
//    (metadata checks; the first hit of a process also re-hashes, shown
//    apart);
//  - remote download throughput of a 2048² three-map result through
//    Cache::Get (GetResult, ReadBlob, SHA-256, write, fsync, atomic install),
//    next to the raw ReadBlob throughput of the same blobs into memory, so the
//    SDK's overhead is visible.
// The result is published into a real impostor-server on loopback through
// WorkerService (no GPU needed): maps of 2048² RGBA8, RGBA16 and RGBA8 with
// incompressible bytes (16 + 32 + 16 MiB, the upper bound of their PNGs).
//
//   cache_bench [--downloads N] [--hits N]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "client/cache/cache_testing.h"
#include "impostor/cache.h"
#include "tests/cache/published_result.h"
#include "tests/integration/server_process.h"

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

double Seconds(Clock::time_point since) { return std::chrono::duration<double>(Clock::now() - since).count(); }

double Percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size())))];
}

double Median(std::vector<double> v) { return Percentile(std::move(v), 0.5); }

}  // namespace

int main(int argc, char** argv) {
  int downloads = 5;
  int hits = 20000;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--downloads") == 0) downloads = std::max(1, std::atoi(argv[i + 1]));
    if (std::strcmp(argv[i], "--hits") == 0) hits = std::max(100, std::atoi(argv[i + 1]));
  }
  const fs::path root = fs::temp_directory_path() / ("impostor_cache_bench_" + std::to_string(::getpid()));
  fs::remove_all(root);
  fs::create_directories(root / "server");
  int exit_code = 0;
  {
    impostor::testing::ServerProcess server(0, root / "server", "127.0.0.1:0");
    const std::vector<int64_t> sizes = {int64_t{2048} * 2048 * 4, int64_t{2048} * 2048 * 8, int64_t{2048} * 2048 * 4};
    const impostor::testing::PublishedResult published = impostor::testing::PublishResult(server, sizes, 7);
    const double mb = static_cast<double>(published.total_bytes) / 1e6;
    std::printf("result %s: 3 maps + manifest.json, %.1f MB, server %s\n", published.key.c_str(), mb,
                server.address().c_str());

    // Raw ReadBlob: the same blobs streamed into memory with a bare stub.
    std::vector<impostor::v1::Digest> digests;
    for (const auto& [name, bytes] : published.files) digests.push_back(impostor::testing::DigestOf(bytes));
    std::vector<double> raw;
    for (int i = 0; i < downloads; ++i) {
      const auto start = Clock::now();
      for (const auto& d : digests) {
        std::string out;
        if (!impostor::testing::ReadBlob(server.assets(), d, &out).ok() ||
            static_cast<int64_t>(out.size()) != d.size_bytes()) {
          std::fprintf(stderr, "raw ReadBlob failed\n");
          return 1;
        }
      }
      raw.push_back(mb / Seconds(start));
    }

    // Cache::Get into a fresh directory each time.
    std::vector<double> sdk;
    for (int i = 0; i < downloads; ++i) {
      impostor::sdk::CacheOptions options;
      options.server = server.address();
      options.dir = root / ("cache-" + std::to_string(i));
      auto cache = impostor::sdk::Cache::Open(options);
      const auto start = Clock::now();
      auto got = cache.ok() ? (*cache)->Get(published.key) : absl::StatusOr<impostor::sdk::CachedResult>(cache.status());
      if (!got.ok()) {
        std::fprintf(stderr, "Get failed: %s\n", got.status().ToString().c_str());
        return 1;
      }
      sdk.push_back(mb / Seconds(start));
    }
    std::printf("download   raw ReadBlob %7.1f MB/s   Cache::Get %7.1f MB/s   (median of %d; Get = %.0f%% of raw)\n",
                Median(raw), Median(sdk), downloads, 100 * Median(sdk) / Median(raw));

    // Local hits on the last cache directory, in a fresh Cache as a restarted
    // game would see them.
    for (auto mode : {impostor::sdk::HitVerification::kDigestOncePerProcess,
                      impostor::sdk::HitVerification::kMetadata}) {
      impostor::sdk::CacheOptions options;
      options.server = "127.0.0.1:1";  // hits must not need it
      options.dir = root / ("cache-" + std::to_string(downloads - 1));
      options.hit_verification = mode;
      auto cache = impostor::sdk::Cache::Open(options);
      if (!cache.ok()) return 1;
      auto start = Clock::now();
      auto first = (*cache)->Get(published.key);
      const double first_ms = Seconds(start) * 1e3;
      if (!first.ok()) {
        std::fprintf(stderr, "hit failed: %s\n", first.status().ToString().c_str());
        return 1;
      }
      std::vector<double> us;
      us.reserve(static_cast<size_t>(hits));
      for (int i = 0; i < hits; ++i) {
        start = Clock::now();
        auto hit = (*cache)->Get(published.key);
        us.push_back(Seconds(start) * 1e6);
        if (!hit.ok()) exit_code = 1;
      }
      std::printf("local hit  %-22s first %.1f ms, then p50 %.1f us  p99 %.1f us  (%d Gets)\n",
                  mode == impostor::sdk::HitVerification::kMetadata ? "kMetadata:" : "kDigestOncePerProcess:",
                  first_ms, Percentile(us, 0.5), Percentile(us, 0.99), hits);
    }
  }
  fs::remove_all(root);
  return exit_code;
}
