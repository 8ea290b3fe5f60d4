// Game clients behind a real CDN (issue 40, "Proof, with real components"):
// a release published from a real impostor-server with `impostor publish`,
// served by an nginx origin, cached by an nginx edge in front of it, and
// fetched by name by a fleet of SDK caches (one per player, each with its
// own directory), all on loopback.
//
//  - Fleet: 100 players x 10 fetches drawn Zipf(1.1) over 60 assets (some
//    sharing their map blobs), all launched while the origin is paused so
//    that every fetch is in flight at once. Every Get succeeds and every
//    installed file hashes to the catalog's digest and holds the bytes the
//    farm was given; the origin's access log shows exactly one GET per
//    distinct blob the fleet asked for (and none for a blob nobody asked
//    for), and one for the catalog. A second wave of fresh players adds no
//    origin request: every blob GET at the edge is a HIT.
//  - Bad edge: an nginx that for four blobs serves a flipped byte, an HTML
//    page with status 200, a truncated file and a stall (an upstream that
//    never answers). With the clean origin second and the farm last every
//    Get ends with the verified file (the four blobs come from the origin);
//    with the farm as the only fallback too; with the bad edge alone, each
//    of the four Gets fails naming the file and its digest, and the cache
//    holds no entry for it, nor any file that does not verify.
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <future>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "common/util/sha256.h"
#include "impostor/cache.h"
#include "tests/delivery/cdn_fleet.h"
#include "tests/delivery/nginx_process.h"
#include "tests/support/server_process.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::AccessLogLine;
using testing::CountGets;
using testing::FleetOptions;
using testing::FleetRun;
using testing::NginxProcess;
using testing::NginxSite;
using testing::PublishedRelease;
using testing::ReadAccessLog;
using testing::ReleaseAsset;
using testing::ReleaseFile;
using testing::ReleaseSpec;
using testing::ServerProcess;

constexpr int kPlayers = 100;
constexpr int kFetchesPerPlayer = 10;
constexpr double kZipfS = 1.1;
constexpr uint32_t kDrawSeed = 4040;

std::string ReadBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

class NginxCdnTest : public ::testing::Test {
 protected:
  void SetUp() override {
    testing::RaiseOpenFileLimit();
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    work_ = testing::NewTempDir(absl::StrCat("nginx_", info->name()));
    farm_ = std::make_unique<ServerProcess>(0);
  }

  void TearDown() override {
    // nginx first (it may hold connections to the silent port), then the farm.
    bad_edge_.reset();
    edge_.reset();
    origin_.reset();
    farm_.reset();
    if (!HasFailure()) fs::remove_all(work_);
  }

  // Publishes `spec` into work_/release and starts the origin on it.
  void PublishAndServe(const ReleaseSpec& spec) {
    absl::StatusOr<PublishedRelease> release = testing::PublishRelease(*farm_, spec, work_ / "release");
    ASSERT_TRUE(release.ok()) << release.status();
    release_ = std::move(*release);
    absl::StatusOr<std::unique_ptr<NginxProcess>> origin =
        NginxProcess::Start(work_ / "origin", testing::OriginSite(release_.root));
    ASSERT_TRUE(origin.ok()) << origin.status();
    origin_ = std::move(*origin);
  }

  std::map<std::string, int> OriginBlobGets() const {
    return CountGets(ReadAccessLog(origin_->access_log()), "/v1/blobs/");
  }

  // Every file `result` installed is the catalog's file of `name`: same
  // names in the same order, each file's bytes hashing to the catalog's
  // digest and equal to what the farm was given.
  void ExpectVerified(const std::string& name, const sdk::CachedResult& result) const {
    const ReleaseAsset* asset = release_.Find(name);
    ASSERT_NE(asset, nullptr) << name;
    EXPECT_EQ(result.key(), asset->key) << name;
    ASSERT_EQ(result.files().size(), asset->files.size()) << name;
    for (size_t i = 0; i < asset->files.size(); ++i) {
      const ReleaseFile& want = asset->files[i];
      const sdk::CachedFile& got = result.files()[i];
      EXPECT_EQ(got.path.filename().string(), want.name) << name;
      EXPECT_EQ(got.sha256, want.sha256) << name << " " << want.name;
      const std::string bytes = ReadBytes(got.path);
      EXPECT_EQ(Sha256Hex(bytes), want.sha256) << name << " " << want.name << " at " << got.path;
      EXPECT_EQ(static_cast<int64_t>(bytes.size()), want.size_bytes) << name << " " << want.name;
      auto published = asset->published.find(want.name);
      ASSERT_NE(published, asset->published.end()) << name << ": the catalog lists " << want.name
                                                    << ", which the farm's result does not have";
      EXPECT_TRUE(bytes == published->second) << name << " " << want.name << ": not the bytes the farm was given";
    }
  }

  void ExpectAllVerified(const FleetRun& run) const {
    ASSERT_TRUE(run.open_error.empty()) << run.open_error;
    int failed = 0;
    for (const testing::FleetFetch& fetch : run.fetches) {
      if (!fetch.result.ok()) {
        if (++failed <= 5) ADD_FAILURE() << "player " << fetch.player << " Get(" << fetch.name << "): " << fetch.result.status();
        continue;
      }
      ExpectVerified(fetch.name, *fetch.result);
    }
    EXPECT_EQ(failed, 0) << "of " << run.fetches.size() << " Gets";
  }

  // Every file under `cache_dir`/entries/<key>/ of a listed asset hashes to
  // that asset's catalog digest for its name: no unverified byte installed.
  void ExpectNoBadFileInstalled(const fs::path& cache_dir) const {
    std::map<std::string, const ReleaseAsset*> by_key;
    for (const ReleaseAsset& asset : release_.assets) by_key[asset.key] = &asset;
    std::error_code ec;
    for (const fs::directory_entry& entry : fs::directory_iterator(cache_dir / "entries", ec)) {
      const std::string key = entry.path().filename().string();
      auto asset = by_key.find(key);
      ASSERT_NE(asset, by_key.end()) << cache_dir << ": an entry " << key << " that the release does not hold";
      for (const fs::directory_entry& file : fs::directory_iterator(entry.path())) {
        const std::string name = file.path().filename().string();
        if (name == ".entry") continue;
        const auto& files = asset->second->files;
        auto want = std::find_if(files.begin(), files.end(), [&](const ReleaseFile& f) { return f.name == name; });
        ASSERT_NE(want, files.end()) << file.path() << ": not a file of " << asset->second->name;
        EXPECT_EQ(Sha256Hex(ReadBytes(file.path())), want->sha256) << file.path() << ": installed unverified";
      }
    }
  }

  fs::path work_;
  std::unique_ptr<ServerProcess> farm_;
  PublishedRelease release_;
  std::unique_ptr<NginxProcess> origin_;
  std::unique_ptr<NginxProcess> edge_;
  std::unique_ptr<NginxProcess> bad_edge_;
};

TEST_F(NginxCdnTest, FleetThroughEdgeReachesOriginOncePerBlob) {
  ReleaseSpec spec;  // 60 assets, maps 2..200 KB, every 6th sharing its maps with the one before
  ASSERT_NO_FATAL_FAILURE(PublishAndServe(spec));
  absl::StatusOr<std::unique_ptr<NginxProcess>> edge = NginxProcess::Start(work_ / "edge", testing::EdgeSite(origin_->url()));
  ASSERT_TRUE(edge.ok()) << edge.status();
  edge_ = std::move(*edge);

  const std::vector<std::vector<int>> draws =
      testing::ZipfDraws(kPlayers, kFetchesPerPlayer, spec.assets, kZipfS, kDrawSeed);
  std::vector<std::vector<std::string>> names;
  std::vector<std::string> all_names;
  size_t expected_blob_gets = 0;  // at the edge: each player fetches each of its distinct blobs at least once
  for (const auto& player : draws) {
    names.emplace_back();
    for (int index : player) names.back().push_back(release_.assets[static_cast<size_t>(index)].name);
    all_names.insert(all_names.end(), names.back().begin(), names.back().end());
    expected_blob_gets += release_.BlobPaths(names.back()).size();
  }
  const std::set<std::string> distinct(all_names.begin(), all_names.end());
  const std::set<std::string> expected_blobs = release_.BlobPaths(all_names);
  std::printf("fleet: %d players x %d fetches over %zu distinct assets (%d published), %zu distinct blobs\n", kPlayers,
              kFetchesPerPlayer, distinct.size(), spec.assets, expected_blobs.size());

  // Wave 1: every Get launched while the origin is paused, so that all
  // thousand are in flight at the edge at once when it is let go.
  FleetOptions options;
  options.root = work_ / "wave1";
  options.mirrors = {edge_->url()};
  options.channel = spec.channel;
  options.server = "";  // a shipped game: mirrors only
  options.max_parallel_downloads = kFetchesPerPlayer;
  options.after_launch = [&] { origin_->Resume(); };
  origin_->Pause();
  FleetRun wave1 = testing::RunSdkFleet(options, names);
  origin_->Resume();  // also when Open failed before after_launch
  std::printf("wave 1: %zu Gets in %.2f s, %lld bytes downloaded\n", wave1.fetches.size(), wave1.wall_seconds,
              static_cast<long long>(wave1.bytes_downloaded));
  EXPECT_EQ(wave1.completed_during_launch, 0) << "a Get ended before the last one was launched";
  ASSERT_NO_FATAL_FAILURE(ExpectAllVerified(wave1));
  for (int p = 0; p < kPlayers; p += 17) {
    char dir[32];
    std::snprintf(dir, sizeof(dir), "player_%03d", p);
    ASSERT_NO_FATAL_FAILURE(ExpectNoBadFileInstalled(options.root / dir));
  }

  // The origin saw each distinct blob the fleet asked for exactly once,
  // and no other blob; the catalog once.
  const std::vector<AccessLogLine> origin_log = ReadAccessLog(origin_->access_log());
  const std::map<std::string, int> blob_gets = CountGets(origin_log, "/v1/blobs/");
  std::set<std::string> seen;
  for (const auto& [path, count] : blob_gets) {
    EXPECT_EQ(count, 1) << "the origin was asked for " << path << " " << count << " times";
    EXPECT_TRUE(expected_blobs.contains(path)) << "the origin was asked for " << path << ", which no player fetched";
    seen.insert(path);
  }
  for (const std::string& path : expected_blobs) EXPECT_TRUE(seen.contains(path)) << path << " never reached the origin";
  EXPECT_EQ(blob_gets.size(), expected_blobs.size());
  for (const AccessLogLine& line : origin_log) {
    EXPECT_EQ(line.status, 200) << "origin: " << line.method << " " << line.uri;
  }
  const std::map<std::string, int> catalog_gets = CountGets(origin_log, "/v1/catalogs/");
  EXPECT_EQ(catalog_gets, (std::map<std::string, int>{{release_.catalog_path, 1}}));
  wave1 = FleetRun{};
  fs::remove_all(options.root);

  // The edge has logged wave 1's blob GETs (it logs a request once its
  // response is out, which a client may see first).
  auto edge_blob_gets = [&] {
    size_t n = 0;
    for (const AccessLogLine& line : ReadAccessLog(edge_->access_log())) {
      n += line.method == "GET" && line.uri.rfind("/v1/blobs/", 0) == 0;
    }
    return n;
  };
  ASSERT_TRUE(testing::WaitForDirectory(edge_->dir(), [&] { return edge_blob_gets() >= expected_blob_gets; },
                                        std::chrono::seconds(30)))
      << "the edge logged " << edge_blob_gets() << " blob GETs, expected at least " << expected_blob_gets;
  const size_t edge_lines_before = ReadAccessLog(edge_->access_log()).size();

  // Wave 2: fresh players asking for the same names are served by the edge alone.
  options.root = work_ / "wave2";
  options.after_launch = nullptr;
  FleetRun wave2 = testing::RunSdkFleet(options, names);
  std::printf("wave 2: %zu Gets in %.2f s, %lld bytes downloaded\n", wave2.fetches.size(), wave2.wall_seconds,
              static_cast<long long>(wave2.bytes_downloaded));
  ASSERT_NO_FATAL_FAILURE(ExpectAllVerified(wave2));
  EXPECT_EQ(OriginBlobGets(), blob_gets) << "wave 2 reached the origin for a blob";
  ASSERT_TRUE(testing::WaitForDirectory(
      edge_->dir(), [&] { return edge_blob_gets() >= 2 * expected_blob_gets; }, std::chrono::seconds(30)));
  const std::vector<AccessLogLine> edge_log = ReadAccessLog(edge_->access_log());
  size_t hits = 0;
  for (size_t i = edge_lines_before; i < edge_log.size(); ++i) {
    const AccessLogLine& line = edge_log[i];
    if (line.method != "GET" || line.uri.rfind("/v1/blobs/", 0) != 0) continue;
    EXPECT_EQ(line.cache_status, "HIT") << "wave 2 at the edge: " << line.uri << " " << line.status;
    EXPECT_EQ(line.status, 200) << line.uri;
    hits += line.cache_status == "HIT";
  }
  EXPECT_GE(hits, expected_blob_gets);
}

// The four ways an edge goes bad, each on one blob.
enum class Fault { kFlippedByte, kHtml200, kTruncated, kStall };

struct FaultCase {
  const char* what;
  Fault fault;
  size_t asset;       // index into the release
  size_t file;        // index into the asset's files
  absl::StatusCode alone_code;  // the Get's code with the bad edge as the only source
};

TEST_F(NginxCdnTest, BadEdgeFallsBackAndNeverInstallsBadBytes) {
  ReleaseSpec spec;
  spec.assets = 8;
  spec.shared_every = 0;  // one fault per asset
  spec.min_map_bytes = 16 * 1024;  // larger than the error page
  spec.max_map_bytes = 64 * 1024;
  spec.seed = 41;
  ASSERT_NO_FATAL_FAILURE(PublishAndServe(spec));

  const std::vector<FaultCase> cases = {
      {"a flipped byte", Fault::kFlippedByte, 0, 0, absl::StatusCode::kDataLoss},
      {"an HTML page with status 200", Fault::kHtml200, 1, 1, absl::StatusCode::kDataLoss},
      {"a truncated file", Fault::kTruncated, 2, 2, absl::StatusCode::kDataLoss},
      {"a stall", Fault::kStall, 3, 0, absl::StatusCode::kDeadlineExceeded},
  };
  testing::SilentPort silent;
  const fs::path crafted = work_ / "crafted";
  fs::create_directories(crafted);
  NginxSite bad;
  bad.name = "bad-edge";
  bad.http = "  log_format requests '$request_method $request_uri $status';\n";
  bad.server = "    access_log {dir}/access.log requests;\n";
  std::set<std::string> bad_paths;
  for (const FaultCase& c : cases) {
    const ReleaseAsset& asset = release_.assets[c.asset];
    const ReleaseFile& file = asset.files[c.file];
    const std::string& bytes = asset.published.at(file.name);
    bad_paths.insert(file.blob_path);
    const fs::path body = crafted / file.sha256;
    std::string location = absl::StrCat("    location = ", file.blob_path, " { ");
    switch (c.fault) {
      case Fault::kFlippedByte: {
        std::string flipped = bytes;
        flipped[flipped.size() / 2] ^= 0x20;
        std::ofstream(body, std::ios::binary) << flipped;
        absl::StrAppend(&location, "alias ", body.string(), ";");
        break;
      }
      case Fault::kHtml200:
        // What a misconfigured CDN or a captive portal answers to anything.
        absl::StrAppend(&location,
                        "default_type text/html; return 200 '<!DOCTYPE html><html><head><title>Service "
                        "unavailable</title></head><body><h1>Please try again later</h1></body></html>';");
        break;
      case Fault::kTruncated:
        std::ofstream(body, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
        absl::StrAppend(&location, "alias ", body.string(), ";");
        break;
      case Fault::kStall:
        absl::StrAppend(&location, "proxy_pass http://127.0.0.1:", silent.port(),
                        "; proxy_connect_timeout 75s; proxy_read_timeout 600s;");
        break;
    }
    absl::StrAppend(&bad.server, location, " }\n");
  }
  // Everything else: the release as published.
  absl::StrAppend(&bad.server, "    location / { root ", release_.root.string(), "; }\n");
  absl::StatusOr<std::unique_ptr<NginxProcess>> started = NginxProcess::Start(work_ / "bad_edge", bad);
  ASSERT_TRUE(started.ok()) << started.status();
  bad_edge_ = std::move(*started);

  std::vector<std::string> all_names;
  for (const ReleaseAsset& asset : release_.assets) all_names.push_back(asset.name);
  FleetOptions options;
  options.channel = spec.channel;
  options.rpc_timeout_seconds = 2;  // the stall is noticed after 2 s without a byte
  options.max_parallel_downloads = spec.assets;

  {
    SCOPED_TRACE("bad edge, clean origin, farm");
    options.root = work_ / "edge_origin_farm";
    options.mirrors = {bad_edge_->url(), origin_->url()};
    options.server = farm_->address();
    const FleetRun run = testing::RunSdkFleet(options, {all_names});
    ASSERT_NO_FATAL_FAILURE(ExpectAllVerified(run));
    ASSERT_NO_FATAL_FAILURE(ExpectNoBadFileInstalled(options.root / "player_000"));
    // The four bad blobs, and only they, came from the origin, once each.
    std::map<std::string, int> want;
    for (const std::string& path : bad_paths) want[path] = 1;
    EXPECT_EQ(OriginBlobGets(), want);
    const std::map<std::string, int> asked_bad = CountGets(ReadAccessLog(bad_edge_->access_log()), "/v1/blobs/");
    for (const std::string& path : bad_paths) EXPECT_TRUE(asked_bad.contains(path)) << path << ": the bad edge was not asked";
  }
  {
    SCOPED_TRACE("bad edge, farm");
    options.root = work_ / "edge_farm";
    options.mirrors = {bad_edge_->url()};
    options.server = farm_->address();
    const auto origin_before = OriginBlobGets();
    const FleetRun run = testing::RunSdkFleet(options, {all_names});
    ASSERT_NO_FATAL_FAILURE(ExpectAllVerified(run));
    ASSERT_NO_FATAL_FAILURE(ExpectNoBadFileInstalled(options.root / "player_000"));
    EXPECT_EQ(OriginBlobGets(), origin_before);
  }
  {
    SCOPED_TRACE("bad edge alone");
    sdk::CacheOptions o;
    o.dir = work_ / "edge_alone";
    o.server = "";
    o.mirrors = {bad_edge_->url()};
    o.channel = spec.channel;
    o.rpc_timeout_seconds = 2;
    absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = sdk::Cache::Open(o);
    ASSERT_TRUE(cache.ok()) << cache.status();
    std::vector<std::future<absl::StatusOr<sdk::CachedResult>>> gets;
    for (const std::string& name : all_names) gets.push_back((*cache)->GetAsync(name));
    std::map<std::string, absl::StatusOr<sdk::CachedResult>> results;
    for (size_t i = 0; i < all_names.size(); ++i) results.emplace(all_names[i], gets[i].get());

    std::set<std::string> faulty_keys;
    for (const FaultCase& c : cases) {
      const ReleaseAsset& asset = release_.assets[c.asset];
      const ReleaseFile& file = asset.files[c.file];
      faulty_keys.insert(asset.key);
      const absl::StatusOr<sdk::CachedResult>& got = results.at(asset.name);
      ASSERT_FALSE(got.ok()) << c.what << ": Get(" << asset.name << ") succeeded from a bad edge alone";
      const std::string message(got.status().message());
      EXPECT_EQ(got.status().code(), c.alone_code) << c.what << ": " << got.status();
      EXPECT_NE(message.find(file.name), std::string::npos) << c.what << ": the message does not name the file "
                                                            << file.name << ": " << message;
      EXPECT_NE(message.find(file.sha256), std::string::npos) << c.what << ": the message does not name the digest "
                                                              << file.sha256 << ": " << message;
      EXPECT_FALSE(fs::exists(o.dir / "entries" / asset.key)) << c.what << ": an entry was installed";
    }
    for (const std::string& name : all_names) {
      const ReleaseAsset* asset = release_.Find(name);
      if (faulty_keys.contains(asset->key)) continue;
      const absl::StatusOr<sdk::CachedResult>& got = results.at(name);
      ASSERT_TRUE(got.ok()) << name << " (no fault): " << got.status();
      ExpectVerified(name, *got);
    }
    for (const sdk::CacheEntryInfo& entry : (*cache)->List()) {
      EXPECT_FALSE(faulty_keys.contains(entry.key)) << "the cache lists " << entry.key << ", which did not verify";
    }
    EXPECT_EQ((*cache)->List().size(), all_names.size() - cases.size());
    results.clear();
    cache->reset();
    ASSERT_NO_FATAL_FAILURE(ExpectNoBadFileInstalled(o.dir));
  }
}

}  // namespace
}  // namespace impostor
