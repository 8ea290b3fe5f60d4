// fleet_bench: a fleet of game clients fetching impostors by name through a
// CDN edge (issue 40), next to curl fetching exactly the same files through
// the same edge with the same concurrency, in the same run.
//
// Setup (shared with tests/delivery/nginx_cdn_test.cc, through
// tests/delivery/cdn_fleet.h and nginx_process.h): a real impostor-server
// holding --assets fake results (maps of 2..200 KB, every 6th asset sharing
// its maps with the one before; no GPU needed), published with the real
// `impostor publish`, served by an nginx origin and cached by an nginx edge
// in front of it. Every player's --fetches names are drawn Zipf(--zipf)
// with a fixed seed. The edge is warmed first (every blob fetched once,
// untimed), so both clients measure edge hits.
//
//  - sdk:  one impostor::sdk::Cache per player (own directory, mirrors =
//          the edge only, no farm), every GetAsync launched at once; per
//          Get the SDK resolves the name through the channel's catalog
//          (two small requests per player), downloads each file, verifies
//          its SHA-256 while it streams, fsyncs and installs atomically.
//  - curl: libcurl's multi interface (Debian's libcurl, the library the
//          curl CLI is) fetching each player's same distinct blob URLs
//          into files, with per player as many transfers at once as its
//          Cache runs downloads (min(distinct names, --max-parallel)), the
//          files of one asset one after another on one connection, as the
//          SDK does. No hashing, no fsync, no catalog. One thread, as
//          the curl CLI's --parallel; --curl-threads T splits the players
//          over T multi handles on T threads (on a busy machine a client
//          with one thread gets less CPU than the SDK's many).
//
// Columns: wall = first request to last file; files and MB actually
// transferred; file p50/p99 = one file's transfer (its first request to its
// last byte); fetch p50/p99 = one asset from the fleet's start to its last
// file (queueing included). --rounds alternates which client goes first;
// the ratio is of the median walls. Target (issue 40): sdk/curl <= 1.3.
// A bench, not a test: nothing is asserted.
//
//   fleet_bench [--players N] [--fetches M] [--assets K] [--rounds R] [--curl-threads T]
#include <curl/curl.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "bench/bench_args.h"
#include "tests/delivery/cdn_fleet.h"
#include "tests/delivery/nginx_process.h"
#include "tests/support/server_process.h"

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using impostor::testing::Percentile;

namespace {

double Seconds(Clock::time_point from, Clock::time_point to) { return std::chrono::duration<double>(to - from).count(); }

// User + system CPU seconds of this process so far, all threads.
double ProcessCpuSeconds() {
  struct rusage u {};
  ::getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-6;
}

// One asset a player fetches: the blob URLs it adds to what the player
// already fetched (a shared blob is fetched once per player, as the SDK's
// partial files make it).
struct AssetFetch {
  int player = 0;
  std::vector<std::string> urls;
  std::vector<fs::path> outs;
  // The player's channel file and catalog, fetched first as the SDK does
  // before it can resolve a name; not counted among the files and fetches.
  bool index = false;
};

struct Measured {
  double wall_seconds = 0;
  double cpu_seconds = 0;  // this process's user + system time (nginx not included)
  int64_t files = 0;
  int64_t bytes = 0;
  int errors = 0;
  std::string first_error;
  std::vector<double> file_seconds;
  std::vector<double> fetch_seconds;  // from the fleet's start
};

// The curl side: `lanes[p]` transfers at once for player p, each working
// through that player's queue of assets, files of an asset in order.
Measured RunCurlFleet(const std::vector<std::vector<AssetFetch>>& per_player, int max_parallel,
                      Clock::time_point start = Clock::now()) {
  struct Lane {
    CURL* easy = nullptr;
    std::deque<const AssetFetch*>* queue = nullptr;
    const AssetFetch* fetch = nullptr;
    size_t next = 0;
    std::FILE* out = nullptr;
    Clock::time_point file_start;
  };
  Measured m;
  CURLM* multi = curl_multi_init();
  std::vector<std::deque<const AssetFetch*>> queues(per_player.size());
  std::vector<std::unique_ptr<Lane>> lanes;
  for (size_t p = 0; p < per_player.size(); ++p) {
    for (const AssetFetch& f : per_player[p]) {
      if (!f.urls.empty()) queues[p].push_back(&f);
    }
    const size_t n = std::min<size_t>(queues[p].size(), static_cast<size_t>(max_parallel));
    for (size_t i = 0; i < n; ++i) {
      auto lane = std::make_unique<Lane>();
      lane->easy = curl_easy_init();
      lane->queue = &queues[p];
      lanes.push_back(std::move(lane));
    }
  }
  // Starts the lane's next file (of its asset, else of the next asset);
  // false when its queue is done.
  auto start_next = [&](Lane& lane) {
    if (lane.fetch == nullptr || lane.next == lane.fetch->urls.size()) {
      if (lane.queue->empty()) return false;
      lane.fetch = lane.queue->front();
      lane.queue->pop_front();
      lane.next = 0;
    }
    const size_t i = lane.next++;
    lane.out = std::fopen(lane.fetch->outs[i].c_str(), "wb");
    if (lane.out == nullptr) {
      std::perror(lane.fetch->outs[i].c_str());
      std::exit(1);
    }
    curl_easy_setopt(lane.easy, CURLOPT_URL, lane.fetch->urls[i].c_str());
    curl_easy_setopt(lane.easy, CURLOPT_WRITEDATA, lane.out);
    curl_easy_setopt(lane.easy, CURLOPT_PRIVATE, &lane);
    curl_easy_setopt(lane.easy, CURLOPT_USERAGENT, "fleet_bench-curl");
    lane.file_start = Clock::now();
    curl_multi_add_handle(multi, lane.easy);
    return true;
  };
  int active = 0;
  for (auto& lane : lanes) active += start_next(*lane) ? 1 : 0;
  while (active > 0) {
    int running = 0;
    curl_multi_perform(multi, &running);
    int queued = 0;
    while (CURLMsg* msg = curl_multi_info_read(multi, &queued)) {
      if (msg->msg != CURLMSG_DONE) continue;
      Lane* lane = nullptr;
      curl_easy_getinfo(msg->easy_handle, CURLINFO_PRIVATE, reinterpret_cast<char**>(&lane));
      const Clock::time_point now = Clock::now();
      long status = 0;
      curl_easy_getinfo(lane->easy, CURLINFO_RESPONSE_CODE, &status);
      curl_off_t size = 0;
      curl_easy_getinfo(lane->easy, CURLINFO_SIZE_DOWNLOAD_T, &size);
      std::fclose(lane->out);
      if (msg->data.result != CURLE_OK || status != 200) {
        if (m.errors++ == 0) {
          m.first_error = absl::StrCat(lane->fetch->urls[lane->next - 1], ": ", curl_easy_strerror(msg->data.result),
                                       " HTTP ", status);
        }
      } else if (!lane->fetch->index) {
        m.files += 1;
        m.bytes += size;
        m.file_seconds.push_back(Seconds(lane->file_start, now));
      }
      if (lane->next == lane->fetch->urls.size() && !lane->fetch->index) {
        m.fetch_seconds.push_back(Seconds(start, now));
      }
      curl_multi_remove_handle(multi, lane->easy);
      if (!start_next(*lane)) active -= 1;
    }
    if (active > 0) curl_multi_poll(multi, nullptr, 0, 100, nullptr);
  }
  m.wall_seconds = Seconds(start, Clock::now());
  for (auto& lane : lanes) curl_easy_cleanup(lane->easy);
  curl_multi_cleanup(multi);
  return m;
}

// RunCurlFleet on `threads` threads, each its own multi handle driving
// every threads-th player; times from one common start. One thread is what
// the curl CLI does (--parallel); more show what a client that uses more
// cores than curl's one would get on a busy machine.
Measured RunCurlFleets(const std::vector<std::vector<AssetFetch>>& per_player, int max_parallel, int threads) {
  std::vector<std::vector<std::vector<AssetFetch>>> parts(static_cast<size_t>(threads));
  for (size_t p = 0; p < per_player.size(); ++p) parts[p % parts.size()].push_back(per_player[p]);
  std::vector<Measured> measured(parts.size());
  const Clock::time_point start = Clock::now();
  {
    std::vector<std::jthread> workers;
    for (size_t t = 0; t < parts.size(); ++t) {
      workers.emplace_back([&, t] { measured[t] = RunCurlFleet(parts[t], max_parallel, start); });
    }
  }
  Measured all;
  all.wall_seconds = Seconds(start, Clock::now());
  for (const Measured& m : measured) {
    all.files += m.files;
    all.bytes += m.bytes;
    all.errors += m.errors;
    if (all.first_error.empty()) all.first_error = m.first_error;
    all.file_seconds.insert(all.file_seconds.end(), m.file_seconds.begin(), m.file_seconds.end());
    all.fetch_seconds.insert(all.fetch_seconds.end(), m.fetch_seconds.begin(), m.fetch_seconds.end());
  }
  return all;
}

struct Row {
  std::string label;
  Measured m;
};

void PrintRow(const Row& row) {
  const Measured& m = row.m;
  const double wall = std::max(m.wall_seconds, 1e-9);
  std::printf("%-12s %8.3f %6.2f %7lld %9.1f %9.0f %8.1f %9.1f %9.1f %9.1f %9.1f %6d\n", row.label.c_str(), m.wall_seconds, m.cpu_seconds,
              static_cast<long long>(m.files), static_cast<double>(m.bytes) / 1e6, static_cast<double>(m.files) / wall,
              static_cast<double>(m.bytes) / 1e6 / wall, Percentile(m.file_seconds, 50) * 1e3,
              Percentile(m.file_seconds, 99) * 1e3, Percentile(m.fetch_seconds, 50) * 1e3,
              Percentile(m.fetch_seconds, 99) * 1e3, m.errors);
}

// The round whose wall time is the median of `rows`.
const Row& MedianRow(std::vector<const Row*> rows) {
  std::sort(rows.begin(), rows.end(), [](const Row* a, const Row* b) { return a->m.wall_seconds < b->m.wall_seconds; });
  return *rows[(rows.size() - 1) / 2];
}

}  // namespace

int main(int argc, char** argv) {
  int players = 100;
  int fetches = 10;
  int assets = 60;
  int rounds = 3;
  int max_parallel = 20;
  double zipf = 1.1;
  int curl_threads = 1;
  std::string only;
  impostor::bench::BenchArgs("fleet_bench",
                             "An SDK fleet fetching by name through an nginx CDN edge, next to curl (libcurl multi) "
                             "fetching the same files through the same edge, same concurrency.")
      .Int("--players", &players, "players, each its own Cache and cache directory (default 100)")
      .Int("--fetches", &fetches, "names each player fetches, drawn Zipf (default 10)")
      .Int("--assets", &assets, "assets published (default 60)")
      .Int("--rounds", &rounds, "rounds of both clients, alternating which goes first (default 3)")
      .Int("--max-parallel", &max_parallel, "CacheOptions::max_parallel_downloads, 1..64 (default 20)")
      .Int("--curl-threads", &curl_threads, "threads of the curl side, each a multi handle (default 1, as the curl CLI)")
      .Text("--only", &only, "run one client only, sdk or curl (to profile it; no ratio printed)")
      .Real("--zipf", &zipf, "the Zipf exponent s of the names drawn (default 1.1)")
      .ParseOrExit(argc, argv);
  if (!only.empty() && only != "sdk" && only != "curl") {
    std::fprintf(stderr, "fleet_bench: --only is sdk or curl, not '%s'\n", only.c_str());
    return 2;
  }
  if (players < 1 || fetches < 1 || assets < 1 || rounds < 1 || max_parallel < 1 || max_parallel > 64 ||
      curl_threads < 1) {
    std::fprintf(stderr, "fleet_bench: --players, --fetches, --assets, --rounds, --curl-threads >= 1; --max-parallel 1..64\n");
    return 2;
  }
  impostor::testing::RaiseOpenFileLimit();
  curl_global_init(CURL_GLOBAL_DEFAULT);
  const fs::path work = impostor::testing::NewTempDir("fleet_bench");

  std::fprintf(stderr, "fleet_bench: publishing %d assets...\n", assets);
  impostor::testing::ServerProcess farm(0);
  impostor::testing::ReleaseSpec spec;
  spec.assets = assets;
  absl::StatusOr<impostor::testing::PublishedRelease> release = impostor::testing::PublishRelease(farm, spec, work / "release");
  if (!release.ok()) {
    std::fprintf(stderr, "fleet_bench: %s\n", release.status().ToString().c_str());
    return 1;
  }
  auto origin = impostor::testing::NginxProcess::Start(work / "origin", impostor::testing::OriginSite(release->root));
  if (!origin.ok()) {
    std::fprintf(stderr, "fleet_bench: %s\n", origin.status().ToString().c_str());
    return 1;
  }
  auto edge = impostor::testing::NginxProcess::Start(work / "edge", impostor::testing::EdgeSite((*origin)->url()));
  if (!edge.ok()) {
    std::fprintf(stderr, "fleet_bench: %s\n", edge.status().ToString().c_str());
    return 1;
  }
  const std::string edge_url = (*edge)->url();

  // The draws, and what each player's Gets download.
  const std::vector<std::vector<int>> draws = impostor::testing::ZipfDraws(players, fetches, assets, zipf, 4040);
  std::vector<std::vector<std::string>> names;
  std::vector<std::vector<std::pair<std::string, std::vector<std::string>>>> player_assets;  // name, new blob paths
  std::set<std::string> all_blobs;
  int64_t blob_fetches = 0;
  for (const auto& player : draws) {
    names.emplace_back();
    player_assets.emplace_back();
    std::set<std::string> seen_names, seen_blobs;
    for (int index : player) {
      const impostor::testing::ReleaseAsset& asset = release->assets[static_cast<size_t>(index)];
      names.back().push_back(asset.name);
      if (!seen_names.insert(asset.name).second) continue;
      std::vector<std::string> fresh;
      for (const auto& f : asset.files) {
        if (seen_blobs.insert(f.blob_path).second) fresh.push_back(f.blob_path);
        all_blobs.insert(f.blob_path);
      }
      blob_fetches += static_cast<int64_t>(fresh.size());
      player_assets.back().emplace_back(asset.name, std::move(fresh));
    }
  }
  auto curl_plan = [&](const fs::path& root) {
    std::vector<std::vector<AssetFetch>> plan(player_assets.size());
    for (size_t p = 0; p < player_assets.size(); ++p) {
      char dir[32];
      std::snprintf(dir, sizeof(dir), "player_%03zu", p);
      fs::create_directories(root / dir);
      // Each player is a game that starts knowing only the channel's name:
      // like the SDK, it reads the channel file and the catalog it names
      // first (curl does not parse them; it is handed the blob URLs).
      AssetFetch index;
      index.player = static_cast<int>(p);
      index.index = true;
      index.urls = {edge_url + "/v1/channels/" + spec.channel + ".json", edge_url + release->catalog_path};
      index.outs = {root / dir / "channel.json", root / dir / "catalog.json"};
      plan[p].push_back(std::move(index));
      for (const auto& [name, paths] : player_assets[p]) {
        AssetFetch f;
        f.player = static_cast<int>(p);
        for (const std::string& path : paths) {
          f.urls.push_back(edge_url + path);
          f.outs.push_back(root / dir / fs::path(path).filename());
        }
        plan[p].push_back(std::move(f));
      }
    }
    return plan;
  };

  // Warm the edge: every blob once (and the channel and catalog), untimed.
  {
    std::vector<std::vector<AssetFetch>> warm(1);
    AssetFetch f;
    fs::create_directories(work / "warm");
    int i = 0;
    for (const std::string& path : all_blobs) {
      f.urls.push_back(edge_url + path);
      f.outs.push_back(work / "warm" / std::to_string(i++));
    }
    f.urls.push_back(edge_url + "/v1/channels/" + spec.channel + ".json");
    f.outs.push_back(work / "warm" / "channel");
    f.urls.push_back(edge_url + release->catalog_path);
    f.outs.push_back(work / "warm" / "catalog");
    for (size_t k = 0; k < f.urls.size(); ++k) {
      AssetFetch one;
      one.urls = {f.urls[k]};
      one.outs = {f.outs[k]};
      warm[0].push_back(std::move(one));
    }
    const Measured w = RunCurlFleet(warm, 16);
    if (w.errors > 0) {
      std::fprintf(stderr, "fleet_bench: warming the edge failed: %s\n", w.first_error.c_str());
      return 1;
    }
  }

  const auto blob_sizes = release->BlobSizes();
  std::vector<Row> rows;
  std::vector<const Row*> sdk_rows, curl_rows;
  rows.reserve(static_cast<size_t>(2 * rounds));
  // Every round's files (and the warm-up's) stay until the end. Deleted
  // between rounds, they made the next round's client pay for them: on an
  // ext4 without a journal (this project's VMs) creating an inode steps
  // over every inode of its group deleted in the last minute, one lookup
  // each (ext4's recently_deleted(), which a journal makes unnecessary), so
  // a round that followed the deletion of the previous one's ~6,000 files
  // spent about a third of its CPU there (2026-12-05: curl ran 2.0x and
  // the SDK 1.6x as fast once the files stayed).
  for (int r = 0; r < rounds; ++r) {
    for (int turn = 0; turn < 2; ++turn) {
      const bool sdk_turn = (turn == 0) == (r % 2 == 0);
      if (!only.empty() && only != (sdk_turn ? "sdk" : "curl")) continue;
      const fs::path root = work / absl::StrCat(sdk_turn ? "sdk_" : "curl_", r);
      Row row;
      row.label = absl::StrCat(sdk_turn ? "sdk" : "curl", " r", r + 1);
      const double cpu_before = ProcessCpuSeconds();
      if (sdk_turn) {
        impostor::testing::FleetOptions options;
        options.root = root;
        options.mirrors = {edge_url};
        options.channel = spec.channel;
        options.server = "";
        options.max_parallel_downloads = max_parallel;
        options.time_files = true;
        const impostor::testing::FleetRun run = impostor::testing::RunSdkFleet(options, names, blob_sizes);
        if (!run.open_error.empty()) {
          std::fprintf(stderr, "fleet_bench: %s\n", run.open_error.c_str());
          return 1;
        }
        row.m.wall_seconds = run.wall_seconds;
        row.m.files = static_cast<int64_t>(run.file_seconds.size());
        row.m.bytes = run.bytes_downloaded;
        row.m.file_seconds = run.file_seconds;
        // A player's Gets of one name share a download: its fetch is the first.
        std::set<std::pair<int, std::string>> counted;
        for (const auto& f : run.fetches) {
          if (!f.result.ok()) {
            if (row.m.errors++ == 0) row.m.first_error = absl::StrCat(f.name, ": ", f.result.status().ToString());
            continue;
          }
          if (counted.insert({f.player, f.name}).second) row.m.fetch_seconds.push_back(f.done_seconds);
        }
      } else {
        row.m = RunCurlFleets(curl_plan(root), max_parallel, curl_threads);
      }
      // Includes closing the players' caches (their threads' exit).
      row.m.cpu_seconds = ProcessCpuSeconds() - cpu_before;
      if (!row.m.first_error.empty()) std::fprintf(stderr, "fleet_bench: %s: %s\n", row.label.c_str(), row.m.first_error.c_str());
      rows.push_back(std::move(row));
      (sdk_turn ? sdk_rows : curl_rows).push_back(&rows.back());
    }
  }

  if (!only.empty()) {
    for (const Row& row : rows) PrintRow(row);
    fs::remove_all(work);
    return 0;
  }
  const Row& sdk = MedianRow(sdk_rows);
  const Row& curl = MedianRow(curl_rows);
  int distinct_assets = 0;
  for (const auto& p : player_assets) distinct_assets += static_cast<int>(p.size());
  std::printf("fleet_bench: %d players x %d fetches (Zipf s=%.2f over %d assets; %d distinct per-player assets, "
              "%lld blob downloads, %zu distinct blobs), through an nginx edge (warm) in front of an nginx origin; "
              "%d transfers at most per player; curl on %d thread(s)\n",
              players, fetches, zipf, assets, distinct_assets, static_cast<long long>(blob_fetches), all_blobs.size(),
              std::min(fetches, max_parallel), curl_threads);
  std::printf("%-12s %8s %6s %7s %9s %9s %8s %9s %9s %9s %9s %6s\n", "client", "wall s", "cpu s", "files", "MB", "files/s", "MB/s",
              "file p50", "file p99", "fetch p50", "fetch p99", "errors");
  std::printf("%-12s %8s %6s %7s %9s %9s %8s %9s %9s %9s %9s %6s\n", "", "", "", "", "", "", "", "ms", "ms", "ms", "ms", "");
  for (const Row& row : rows) PrintRow(row);
  PrintRow({"sdk median", sdk.m});
  PrintRow({"curl median", curl.m});
  std::printf("sdk/curl wall: %.2fx (issue 40's target: <= 1.3x)\n",
              sdk.m.wall_seconds / std::max(curl.m.wall_seconds, 1e-9));
  std::fflush(stdout);
  edge->reset();
  origin->reset();
  fs::remove_all(work);
  curl_global_cleanup();
  return 0;
}
