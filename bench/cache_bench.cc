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
// With --nginx PATH (bench/fetch_bench.sh passes it, installing Debian's
// nginx-light when missing) it also serves the same files from a temporary
// directory with nginx, fetches them with curl, runs `impostor fetch KEY
// --out DIR` (the CLI next to this binary) and prints both SDK paths as
// ratios to curl's time, all in the same run (issue 18's 1.5x target).
//
//   cache_bench [--downloads N] [--hits N] [--nginx PATH]
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "bench/bench_args.h"
#include "client/cache/cache_testing.h"
#include "impostor/cache.h"
#include "tests/support/published_result.h"
#include "tests/support/server_process.h"

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

double Seconds(Clock::time_point since) { return std::chrono::duration<double>(Clock::now() - since).count(); }

double Percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size())))];
}

double Median(std::vector<double> v) { return Percentile(std::move(v), 0.5); }

// A TCP port free on 127.0.0.1 now (the OS picks it for a bind to 0).
int FreePort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof(addr);
  int port = 0;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0 &&
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) == 0) {
    port = ntohs(addr.sin_port);
  }
  ::close(fd);
  return port;
}

// Seconds `command` took (a shell), or -1 when it failed.
double TimeCommand(const std::string& command) {
  const auto start = Clock::now();
  if (std::system(command.c_str()) != 0) {
    std::fprintf(stderr, "failed: %s\n", command.c_str());
    return -1;
  }
  return Seconds(start);
}

// Serves `files` with nginx from `root`/www on a port picked by the OS and
// times curl fetching them all to disk, `fetch_cmd` (impostor fetch), and
// prints the medians with their ratio. Returns false on any failure.
bool CompareWithNginx(const std::string& nginx, const fs::path& root, const std::map<std::string, std::string>& files,
                      const std::string& fetch_cmd, double mb, int runs, double cache_get_s) {
  const fs::path www = root / "www";
  fs::create_directories(www);
  for (const auto& [name, bytes] : files) std::ofstream(www / name, std::ios::binary) << bytes;
  // A free port: bind to 0, read it, close (nginx binds it a moment later).
  const int port = FreePort();
  {
    std::ofstream conf(root / "nginx.conf");
    conf << "daemon on; worker_processes 1; pid " << (root / "nginx.pid").string() << ";\n"
         << "error_log " << (root / "nginx.err").string() << ";\n"
         << "events { worker_connections 64; }\n"
         << "http { access_log off; sendfile on; tcp_nopush on;\n"
         << "  client_body_temp_path " << root.string() << "; proxy_temp_path " << root.string() << ";\n"
         << "  fastcgi_temp_path " << root.string() << "; uwsgi_temp_path " << root.string() << ";\n"
         << "  scgi_temp_path " << root.string() << ";\n"
         << "  server { listen 127.0.0.1:" << port << "; root " << www.string() << "; } }\n";
  }
  if (std::system((nginx + " -c " + (root / "nginx.conf").string() + " -p " + root.string()).c_str()) != 0) {
    std::fprintf(stderr, "nginx did not start (see %s)\n", (root / "nginx.err").c_str());
    return false;
  }
  std::string curl = "curl -sf";
  for (const auto& [name, bytes] : files) {
    curl += " -o " + (root / "curl" / name).string() + " http://127.0.0.1:" + std::to_string(port) + "/" + name;
  }
  std::vector<double> curl_s, fetch_s;
  bool ok = true;
  for (int i = 0; i < runs && ok; ++i) {
    fs::remove_all(root / "curl");
    fs::create_directories(root / "curl");
    const double c = TimeCommand(curl);
    fs::remove_all(root / "fetched");
    const double f = TimeCommand(fetch_cmd + " --out " + (root / "fetched").string() + " --quiet > /dev/null");
    ok = c > 0 && f > 0;
    curl_s.push_back(c);
    fetch_s.push_back(f);
  }
  std::system(("kill $(cat " + (root / "nginx.pid").string() + ")").c_str());
  if (!ok) return false;
  const double curl_med = Median(curl_s);
  std::printf("nginx+curl %7.3f s (%6.1f MB/s)   impostor fetch %7.3f s = %.2fx curl   Cache::Get %7.3f s = %.2fx curl"
              "   (median of %d, the same files)\n",
              curl_med, mb / curl_med, Median(fetch_s), Median(fetch_s) / curl_med, cache_get_s,
              cache_get_s / curl_med, runs);
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  int downloads = 5;
  int hits = 20000;
  std::string nginx;
  impostor::bench::BenchArgs("cache_bench", "The game-client cache's hit latency and download throughput.")
      .Int("--downloads", &downloads, "downloads to time (default 5, at least 1)")
      .Int("--hits", &hits, "local cache hits to time (default 20000, at least 100)")
      .Text("--nginx", &nginx, "an nginx binary to serve the same files for comparison")
      .ParseOrExit(argc, argv);
  downloads = std::max(1, downloads);
  hits = std::max(100, hits);
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
    std::vector<double> sdk, sdk_s;
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
      sdk_s.push_back(Seconds(start));
      sdk.push_back(mb / sdk_s.back());
    }
    std::printf("download   raw ReadBlob %7.1f MB/s   Cache::Get %7.1f MB/s   (median of %d; Get = %.0f%% of raw)\n",
                Median(raw), Median(sdk), downloads, 100 * Median(sdk) / Median(raw));
    if (!nginx.empty()) {
      const fs::path cli = fs::read_symlink("/proc/self/exe").parent_path() / "impostor";
      const std::string fetch = cli.string() + " fetch " + published.key + " --server " + server.address();
      if (!CompareWithNginx(nginx, root, published.files, fetch, mb, downloads, Median(sdk_s))) return 1;
    }

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
