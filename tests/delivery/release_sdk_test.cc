// Releases end to end, without a GPU: results put into a real
// impostor-server (tests/support/published_result.h), published with the
// `impostor publish` CLI into a release tree, served by in-process HTTP
// mirrors that can misbehave (fault_mirror.h), and fetched by asset name
// through the SDK's cache and the CLI. What each test holds is in its name.
#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <thread>

#include <nlohmann/json.hpp>

#include "client/delivery/catalog.h"
#include "client/delivery/release_paths.h"
#include "common/util/sha256.h"
#include "impostor/cache.h"
#include "impostor/impostor_c.h"
#include "tests/support/published_result.h"
#include "tests/delivery/fault_mirror.h"
#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string Hex(const std::string& bytes) { return Sha256Hex(bytes); }

class ReleaseTest : public ::testing::Test {
 protected:
  void SetUp() override {
    server_ = std::make_unique<ServerProcess>(0);
    dir_ = NewTempDir(std::string("release_") + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    tree_ = dir_ / "release";
    // Three results; "oak" and "oak-variant" share their map blobs.
    oak_ = PublishResult(*server_, {3000, 2000, 1500}, 11, false, /*map_seed=*/77);
    oak_variant_ = PublishResult(*server_, {3000, 2000, 1500}, 12, false, /*map_seed=*/77);
    rock_ = PublishResult(*server_, {4000, 1000, 900}, 13);
  }
  void TearDown() override {
    const fs::path data = server_->data_dir();
    server_.reset();
    fs::remove_all(data);
    fs::remove_all(dir_);
  }

  ToolRun Impostor(std::vector<std::string> args) {
    args.insert(args.begin(), (BinaryDir() / "impostor").string());
    return RunTool(args, std::chrono::seconds(120));
  }
  ToolRun Publish(const std::vector<std::string>& inputs, const std::string& channel = "nightly",
                  std::vector<std::string> extra = {}) {
    std::vector<std::string> args{"publish"};
    args.insert(args.end(), inputs.begin(), inputs.end());
    for (const std::string& a :
         {std::string("--channel"), channel, std::string("--out"), tree_.string(), std::string("--server"),
          server_->address(), std::string("--json")}) {
      args.push_back(a);
    }
    args.insert(args.end(), extra.begin(), extra.end());
    return Impostor(args);
  }
  std::vector<std::string> DefaultInputs() {
    return {"trees/oak=" + oak_.key, "trees/oak-variant=" + oak_variant_.key, "rocks/granite=" + rock_.key};
  }
  std::string ChannelBytes(const std::string& channel = "nightly") {
    return ReadFileBytes(tree_ / delivery::ChannelPath(channel));
  }
  delivery::Catalog CurrentCatalog(const std::string& channel = "nightly") {
    absl::StatusOr<delivery::ChannelPointer> p = delivery::ParseChannel(ChannelBytes(channel), "channel");
    EXPECT_TRUE(p.ok()) << p.status();
    const std::string text = ReadFileBytes(tree_ / delivery::CatalogPath(p->catalog_sha256));
    EXPECT_EQ(Hex(text), p->catalog_sha256);
    absl::StatusOr<delivery::Catalog> c = delivery::ParseCatalog(text, "catalog");
    EXPECT_TRUE(c.ok()) << c.status();
    return *c;
  }
  // Every content-addressed file under the tree, by path, and whether its
  // bytes hash to its name.
  std::map<std::string, std::string> ContentFiles() {
    std::map<std::string, std::string> out;
    for (const char* kind : {"blobs", "catalogs"}) {
      const fs::path dir = tree_ / "v1" / kind / "sha256";
      if (!fs::exists(dir)) continue;
      for (const auto& e : fs::recursive_directory_iterator(dir)) {
        if (!e.is_regular_file()) continue;
        const std::string bytes = ReadFileBytes(e.path());
        EXPECT_EQ(Hex(bytes), e.path().filename().string()) << e.path() << " does not hold what its name says";
        out[fs::relative(e.path(), tree_).string()] = Hex(bytes);
      }
    }
    return out;
  }
  sdk::CacheOptions GameOptions(std::vector<std::string> mirrors, const std::string& cache = "game") {
    sdk::CacheOptions o;
    o.server = "";
    o.mirrors = std::move(mirrors);
    o.channel = "nightly";
    o.dir = dir_ / cache;
    o.rpc_timeout_seconds = 1;  // a stalled mirror is left after ~1 s
    o.max_attempts = 2;
    o.catalog_refresh_seconds = 0;
    return o;
  }
  // The blob paths of an asset's files, by file name.
  std::map<std::string, std::string> BlobPaths(const std::string& name) {
    std::map<std::string, std::string> out;
    const delivery::Catalog catalog = CurrentCatalog();
    for (const delivery::CatalogFile& f : catalog.assets.at(name).files) {
      out[f.name] = delivery::BlobPath(f.sha256);
    }
    return out;
  }
  static void ExpectVerified(const sdk::CachedResult& r, const PublishedResult& published) {
    ASSERT_TRUE(r.valid());
    for (const sdk::CachedFile& f : r.files()) {
      const std::string bytes = ReadFileBytes(f.path);
      EXPECT_EQ(Hex(bytes), f.sha256) << f.path;
      auto it = published.files.find(f.path.filename().string());
      ASSERT_NE(it, published.files.end()) << f.path;
      EXPECT_EQ(bytes, it->second) << f.path << " differs from what the farm holds";
    }
  }

  std::unique_ptr<ServerProcess> server_;
  fs::path dir_;
  fs::path tree_;
  PublishedResult oak_, oak_variant_, rock_;
};

TEST_F(ReleaseTest, PublishWritesBlobsCatalogAndChannelAndIsIdempotent) {
  ToolRun first = Publish(DefaultInputs());
  ASSERT_EQ(first.exit_code, 0) << first.err;
  const json a = json::parse(first.out);
  // 3 maps + manifest per result; oak and its variant share their maps.
  EXPECT_EQ(a["assets"], 3);
  EXPECT_EQ(a["blobs_written"], 3 + 1 + 1 + 3 + 1);
  EXPECT_EQ(a["blobs_present"], 0);
  EXPECT_EQ(a["channel_changed"], true);
  const delivery::Catalog catalog = CurrentCatalog();
  ASSERT_EQ(catalog.assets.size(), 3u);
  EXPECT_EQ(catalog.assets.at("trees/oak").cache_key, oak_.key);
  EXPECT_EQ(catalog.assets.at("rocks/granite").files.size(), 4u);
  EXPECT_EQ(catalog.assets.at("rocks/granite").files.back().name, "manifest.json");
  const std::map<std::string, std::string> before = ContentFiles();
  EXPECT_EQ(before.size(), 9u + 1u);  // 9 blobs, 1 catalog

  // The same inputs again: the same catalog digest, nothing written.
  ToolRun again = Publish(DefaultInputs());
  ASSERT_EQ(again.exit_code, 0) << again.err;
  const json b = json::parse(again.out);
  EXPECT_EQ(b["catalog_sha256"], a["catalog_sha256"]);
  EXPECT_EQ(b["blobs_written"], 0);
  EXPECT_EQ(b["blobs_present"], 9);
  EXPECT_EQ(b["catalog_reused"], true);
  EXPECT_EQ(b["channel_changed"], false);
  EXPECT_EQ(ContentFiles(), before);
}

TEST_F(ReleaseTest, ASecondReleaseNeverChangesBytesUnderAUrlAndTheChannelFlipIsAtomic) {
  ASSERT_EQ(Publish({"trees/oak=" + oak_.key}).exit_code, 0);
  const std::map<std::string, std::string> first = ContentFiles();
  // A reader polls the channel (as an edge revalidating it would) while two
  // releases alternate: every read is a whole channel file naming a catalog
  // that is in the tree, whose blobs are all there.
  std::atomic<bool> stop{false};
  std::atomic<int> reads{0};
  std::atomic<int> bad{0};
  std::thread poller([&] {
    while (!stop) {
      const std::string text = ReadFileBytes(tree_ / delivery::ChannelPath("nightly"));
      absl::StatusOr<delivery::ChannelPointer> p = delivery::ParseChannel(text, "poll");
      if (!p.ok() || !fs::exists(tree_ / delivery::CatalogPath(p->catalog_sha256))) {
        ++bad;
      } else {
        absl::StatusOr<delivery::Catalog> c =
            delivery::ParseCatalog(ReadFileBytes(tree_ / delivery::CatalogPath(p->catalog_sha256)), "poll");
        if (!c.ok()) ++bad;
        for (const auto& [name, asset] : c.ok() ? c->assets : std::map<std::string, delivery::CatalogAsset>{}) {
          for (const auto& f : asset.files) {
            if (!fs::exists(tree_ / delivery::BlobPath(f.sha256))) ++bad;
          }
        }
      }
      ++reads;
    }
  });
  for (int round = 0; round < 3; ++round) {
    ASSERT_EQ(Publish(DefaultInputs()).exit_code, 0);
    ASSERT_EQ(Publish({"trees/oak=" + oak_.key, "rocks/granite=" + rock_.key}).exit_code, 0);
  }
  stop = true;
  poller.join();
  EXPECT_GT(reads.load(), 0);
  EXPECT_EQ(bad.load(), 0) << "a reader saw a torn or dangling channel";
  // Every path that existed holds the same bytes it held at first.
  const std::map<std::string, std::string> later = ContentFiles();
  for (const auto& [path, hash] : first) {
    ASSERT_TRUE(later.contains(path)) << path;
    EXPECT_EQ(later.at(path), hash) << path;
  }
  EXPECT_EQ(CurrentCatalog().assets.size(), 2u);
}

TEST_F(ReleaseTest, BadInputsAreRefusedAndLeaveTheChannelAlone) {
  ASSERT_EQ(Publish(DefaultInputs()).exit_code, 0);
  const std::string channel = ChannelBytes();
  struct Case {
    const char* what;
    std::vector<std::string> inputs;
    std::string channel;
    int exit_code;
    std::string says;
  };
  const std::string unknown(64, 'e');
  const std::vector<Case> cases = {
      {"one name, two keys", {"trees/oak=" + oak_.key, "trees/oak=" + rock_.key}, "nightly", 2, "two results"},
      {"traversal", {"../oak=" + oak_.key}, "nightly", 2, ". or .."},
      {"absolute", {"/etc/oak=" + oak_.key}, "nightly", 2, "must not start with /"},
      {"not a key", {"trees/oak=1234"}, "nightly", 2, "NAME=KEY"},
      {"bad channel", {"trees/oak=" + oak_.key}, "../nightly", 2, "--channel"},
      {"unknown key", {"trees/oak=" + oak_.key, "trees/ghost=" + unknown}, "nightly", 1, "trees/ghost"},
  };
  for (const Case& c : cases) {
    ToolRun run = Publish(c.inputs, c.channel);
    EXPECT_EQ(run.exit_code, c.exit_code) << c.what << ": " << run.err;
    EXPECT_NE(run.err.find(c.says), std::string::npos) << c.what << ": " << run.err;
    EXPECT_EQ(ChannelBytes(), channel) << c.what << " changed the channel";
  }
  // A failed asset in a bake-batch report stops the publish, naming it.
  const fs::path report = dir_ / "report.json";
  {
    std::ofstream out(report);
    out << json{{"type", "asset"}, {"asset", "a/oak.glb"}, {"name", "oak"}, {"status", "succeeded"},
                {"cache_key", oak_.key}}.dump()
        << "\n"
        << json{{"type", "asset"}, {"asset", "a/elm.glb"}, {"name", "elm"}, {"status", "failed"},
                {"cache_key", nullptr}}.dump()
        << "\n";
  }
  ToolRun from_report = Publish({}, "nightly", {"--from-report", report.string()});
  EXPECT_EQ(from_report.exit_code, 1) << from_report.err;
  EXPECT_NE(from_report.err.find("\"elm\""), std::string::npos) << from_report.err;
  EXPECT_EQ(ChannelBytes(), channel);
}

TEST_F(ReleaseTest, GameFetchesByNameAndEveryBadMirrorMovesOnToTheNext) {
  ASSERT_EQ(Publish(DefaultInputs()).exit_code, 0);
  FaultMirror edge(tree_);
  FaultMirror origin(tree_);
  const std::map<std::string, std::string> oak = BlobPaths("trees/oak");
  const std::map<std::string, std::string> rock = BlobPaths("rocks/granite");
  // Four files of two assets, four ways a CDN edge goes wrong.
  edge.SetFault(oak.at("albedo_alpha.png"), Fault::kFlipByte);
  edge.SetFault(oak.at("normal_depth.png"), Fault::kHtml200);
  edge.SetFault(rock.at("orm.png"), Fault::kTruncate);
  edge.SetFault(rock.at("albedo_alpha.png"), Fault::kStall);
  edge.SetFault(rock.at("manifest.json"), Fault::kNotFound);

  absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = sdk::Cache::Open(GameOptions({edge.url(), origin.url()}));
  ASSERT_TRUE(cache.ok()) << cache.status();
  absl::StatusOr<sdk::CachedResult> got_oak = (*cache)->Get("trees/oak");
  ASSERT_TRUE(got_oak.ok()) << got_oak.status();
  EXPECT_EQ(got_oak->key(), oak_.key);
  EXPECT_TRUE(got_oak->downloaded());
  ExpectVerified(*got_oak, oak_);
  absl::StatusOr<sdk::CachedResult> got_rock = (*cache)->Get("rocks/granite");
  ASSERT_TRUE(got_rock.ok()) << got_rock.status();
  ExpectVerified(*got_rock, rock_);
  // The bad files came from the origin; the good ones from the edge alone.
  for (const std::string& path : {oak.at("albedo_alpha.png"), oak.at("normal_depth.png"), rock.at("orm.png"),
                                  rock.at("albedo_alpha.png"), rock.at("manifest.json")}) {
    EXPECT_GE(edge.Requests(path), 1) << path;
    EXPECT_EQ(origin.Requests(path), 1) << path;
  }
  EXPECT_EQ(origin.Requests(oak.at("orm.png")), 0);
  EXPECT_EQ(edge.Requests(oak.at("orm.png")), 1);

  // A second Get is a local hit: no request anywhere.
  const int before = edge.TotalRequests() + origin.TotalRequests();
  absl::StatusOr<sdk::CachedResult> hit = (*cache)->Get("trees/oak");
  ASSERT_TRUE(hit.ok()) << hit.status();
  EXPECT_FALSE(hit->downloaded());
  EXPECT_EQ(edge.TotalRequests() + origin.TotalRequests(), before + 1) << "only the channel file is revalidated";

  // Names the catalog lacks, and names that are no names.
  EXPECT_EQ((*cache)->Get("trees/birch").status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ((*cache)->Get("../etc/passwd").status().code(), absl::StatusCode::kInvalidArgument);
}

TEST_F(ReleaseTest, WithNoGoodSourceLeftTheErrorNamesFileAndDigestAndNothingIsInstalled) {
  ASSERT_EQ(Publish(DefaultInputs()).exit_code, 0);
  FaultMirror edge(tree_);
  const std::map<std::string, std::string> oak = BlobPaths("trees/oak");
  edge.SetFault(oak.at("orm.png"), Fault::kFlipByte);
  absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = sdk::Cache::Open(GameOptions({edge.url()}));
  ASSERT_TRUE(cache.ok()) << cache.status();
  absl::StatusOr<sdk::CachedResult> got = (*cache)->Get("trees/oak");
  ASSERT_FALSE(got.ok());
  EXPECT_EQ(got.status().code(), absl::StatusCode::kDataLoss) << got.status();
  const std::string digest = fs::path(oak.at("orm.png")).filename().string();
  EXPECT_NE(got.status().message().find(digest), absl::string_view::npos) << got.status();
  EXPECT_TRUE((*cache)->List().empty());

  // With the farm as the last source, the same fetch succeeds from it.
  sdk::CacheOptions with_farm = GameOptions({edge.url()}, "game-with-farm");
  with_farm.server = server_->address();
  absl::StatusOr<std::unique_ptr<sdk::Cache>> farm_cache = sdk::Cache::Open(with_farm);
  ASSERT_TRUE(farm_cache.ok()) << farm_cache.status();
  absl::StatusOr<sdk::CachedResult> from_farm = (*farm_cache)->Get("trees/oak");
  ASSERT_TRUE(from_farm.ok()) << from_farm.status();
  ExpectVerified(*from_farm, oak_);
}

TEST_F(ReleaseTest, OfflineAGameResolvesNamesFromItsCachedCatalogAndServesCachedFiles) {
  ASSERT_EQ(Publish(DefaultInputs()).exit_code, 0);
  {
    FaultMirror mirror(tree_);
    absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = sdk::Cache::Open(GameOptions({mirror.url()}));
    ASSERT_TRUE(cache.ok()) << cache.status();
    ASSERT_TRUE((*cache)->Get("trees/oak").ok());
  }
  // Every mirror and the farm gone; the game restarts.
  const std::string gone = "http://127.0.0.1:1";
  sdk::CacheOptions options = GameOptions({gone});
  options.server = "";
  server_->Kill();
  absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = sdk::Cache::Open(options);
  ASSERT_TRUE(cache.ok()) << cache.status();
  absl::StatusOr<sdk::CachedResult> oak = (*cache)->Get("trees/oak");
  ASSERT_TRUE(oak.ok()) << oak.status();
  EXPECT_FALSE(oak->downloaded());
  ExpectVerified(*oak, oak_);
  // An asset it never fetched cannot come from anywhere: said, not hung.
  absl::StatusOr<sdk::CachedResult> rock = (*cache)->Get("rocks/granite");
  EXPECT_EQ(rock.status().code(), absl::StatusCode::kUnavailable) << rock.status();
  // A fresh game that never saw the channel has nothing to go on.
  absl::StatusOr<std::unique_ptr<sdk::Cache>> fresh = sdk::Cache::Open(GameOptions({gone}, "fresh"));
  ASSERT_TRUE(fresh.ok());
  EXPECT_EQ((*fresh)->Get("trees/oak").status().code(), absl::StatusCode::kUnavailable);
}

TEST_F(ReleaseTest, SignedCatalogsVerifyAndAnotherKeyIsRefused) {
  for (const char* name : {"a", "b"}) {
    const fs::path key = dir_ / (std::string(name) + ".pem");
    ASSERT_EQ(std::system(("openssl genpkey -algorithm ed25519 -out " + key.string() + " 2>/dev/null").c_str()), 0);
    ASSERT_EQ(std::system(("openssl pkey -in " + key.string() + " -pubout -out " +
                           (dir_ / (std::string(name) + ".pub")).string() + " 2>/dev/null")
                              .c_str()),
              0);
  }
  ToolRun signed_run = Publish(DefaultInputs(), "nightly", {"--sign-key", (dir_ / "a.pem").string()});
  ASSERT_EQ(signed_run.exit_code, 0) << signed_run.err;
  FaultMirror mirror(tree_);
  sdk::CacheOptions good = GameOptions({mirror.url()}, "good");
  good.catalog_public_key_file = (dir_ / "a.pub").string();
  absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = sdk::Cache::Open(good);
  ASSERT_TRUE(cache.ok()) << cache.status();
  ASSERT_TRUE((*cache)->Get("trees/oak").ok());
  sdk::CacheOptions other = GameOptions({mirror.url()}, "other");
  other.catalog_public_key_file = (dir_ / "b.pub").string();
  absl::StatusOr<std::unique_ptr<sdk::Cache>> refused = sdk::Cache::Open(other);
  ASSERT_TRUE(refused.ok());
  EXPECT_EQ((*refused)->Get("trees/oak").status().code(), absl::StatusCode::kPermissionDenied);
  // Options that cannot work are refused at Open, naming the field.
  sdk::CacheOptions bad = GameOptions({"ftp://x"});
  EXPECT_NE(sdk::Cache::Open(bad).status().message().find("mirrors[0]"), absl::string_view::npos);
  bad = GameOptions({mirror.url()});
  bad.channel = "";
  EXPECT_NE(sdk::Cache::Open(bad).status().message().find("channel"), absl::string_view::npos);
  bad = GameOptions({});
  EXPECT_NE(sdk::Cache::Open(bad).status().message().find("server"), absl::string_view::npos);
  bad = GameOptions({mirror.url()});
  bad.catalog_public_key_file = (dir_ / "a.pem").string() + ".missing";
  EXPECT_NE(sdk::Cache::Open(bad).status().message().find("catalog_public_key_file"), absl::string_view::npos);
}

TEST_F(ReleaseTest, PrefetchByNameWithPrioritiesAndTheCli) {
  ASSERT_EQ(Publish(DefaultInputs()).exit_code, 0);
  FaultMirror mirror(tree_);
  absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = sdk::Cache::Open(GameOptions({mirror.url()}));
  ASSERT_TRUE(cache.ok()) << cache.status();
  std::mutex mu;
  std::map<std::string, absl::Status> outcomes;
  std::condition_variable cv;
  (*cache)->Prefetch({"trees/oak", "rocks/granite", "trees/ghost"}, 5,
                     [&](const std::string& name, const absl::Status& s) {
                       std::lock_guard lock(mu);
                       outcomes[name] = s;
                       cv.notify_all();
                     });
  {
    std::unique_lock lock(mu);
    ASSERT_TRUE(cv.wait_for(lock, std::chrono::seconds(60), [&] { return outcomes.size() == 3; }));
  }
  EXPECT_TRUE(outcomes["trees/oak"].ok()) << outcomes["trees/oak"];
  EXPECT_TRUE(outcomes["rocks/granite"].ok()) << outcomes["rocks/granite"];
  EXPECT_EQ(outcomes["trees/ghost"].code(), absl::StatusCode::kNotFound);
  EXPECT_EQ((*cache)->List().size(), 2u);
  EXPECT_EQ((*cache)->CancelPrefetch({"trees/oak"}), 0) << "nothing left to cancel";

  // The CLI: catalog ls and fetch by name, mirrors only.
  const fs::path cli_cache = dir_ / "cli-cache";
  ToolRun ls = Impostor({"catalog", "ls", "--mirror", mirror.url(), "--channel", "nightly", "--cache-dir",
                         cli_cache.string()});
  ASSERT_EQ(ls.exit_code, 0) << ls.err;
  EXPECT_NE(ls.out.find("trees/oak-variant  " + oak_variant_.key), std::string::npos) << ls.out;
  EXPECT_NE(ls.out.find("3 assets"), std::string::npos) << ls.out;
  const fs::path out = dir_ / "fetched";
  ToolRun fetch = Impostor({"fetch", "rocks/granite", "--mirror", "http://127.0.0.1:1," + mirror.url(), "--channel",
                            "nightly", "--out", out.string(), "--cache-dir", cli_cache.string(), "--json"});
  ASSERT_EQ(fetch.exit_code, 0) << fetch.err;
  const json report = json::parse(fetch.out);
  EXPECT_EQ(report["cache_key"], rock_.key);
  for (const auto& [name, bytes] : rock_.files) EXPECT_EQ(ReadFileBytes(out / name), bytes) << name;
  ToolRun missing = Impostor({"fetch", "rocks/basalt", "--mirror", mirror.url(), "--channel", "nightly", "--out",
                              out.string(), "--cache-dir", cli_cache.string()});
  EXPECT_EQ(missing.exit_code, 1) << missing.err;
  EXPECT_NE(missing.err.find("rocks/basalt"), std::string::npos) << missing.err;
  ToolRun usage = Impostor({"fetch", "rocks/granite", "--mirror", mirror.url(), "--out", out.string()});
  EXPECT_EQ(usage.exit_code, 2) << usage.err;
}

// The C API reads releases too: the sized options' mirrors and channel, a
// Get by name, prioritised prefetch and its cancellation.
TEST_F(ReleaseTest, TheCApiFetchesByNameFromMirrors) {
  ASSERT_EQ(Publish(DefaultInputs()).exit_code, 0);
  FaultMirror edge(tree_);
  FaultMirror origin(tree_);
  edge.SetFault(BlobPaths("trees/oak").at("orm.png"), Fault::kFlipByte);
  const std::string mirrors = edge.url() + "," + origin.url();
  const std::string dir = (dir_ / "c-game").string();
  impostor_cache_options o;
  impostor_cache_options_init(&o);
  o.server = nullptr;  // mirrors only
  o.dir = dir.c_str();
  o.rpc_timeout_seconds = 1;
  impostor_cache_options_ext ext;
  impostor_cache_options_ext_init(&ext);
  ext.mirrors = mirrors.c_str();
  ext.channel = "nightly";
  impostor_cache* cache = nullptr;
  ASSERT_EQ(impostor_cache_open_ext(&o, &ext, &cache), IMPOSTOR_OK) << impostor_last_error();
  impostor_result* oak = nullptr;
  ASSERT_EQ(impostor_cache_get(cache, "trees/oak", &oak), IMPOSTOR_OK) << impostor_last_error();
  EXPECT_EQ(std::string(impostor_result_key(oak)), oak_.key);
  EXPECT_EQ(ReadFileBytes(impostor_result_map_path(oak, "orm")), oak_.files.at("orm.png"));
  impostor_result_release(oak);
  impostor_result* ghost = nullptr;
  EXPECT_EQ(impostor_cache_get(cache, "trees/ghost", &ghost), IMPOSTOR_NOT_FOUND);
  EXPECT_NE(std::string(impostor_last_error()).find("trees/ghost"), std::string::npos) << impostor_last_error();
  const char* names[] = {"rocks/granite"};
  impostor_cache_prefetch_priority(cache, names, 1, 7);
  impostor_result* rock = nullptr;
  ASSERT_EQ(impostor_cache_get(cache, "rocks/granite", &rock), IMPOSTOR_OK) << impostor_last_error();
  impostor_result_release(rock);
  EXPECT_EQ(impostor_cache_cancel_prefetch(cache, names, 1), 0) << "it is installed: nothing left to cancel";
  impostor_cache_close(cache);

  // Bad release options are refused at open, naming the field.
  ext.channel = "../x";
  EXPECT_EQ(impostor_cache_open_ext(&o, &ext, &cache), IMPOSTOR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(impostor_last_error()).find("channel"), std::string::npos) << impostor_last_error();
}

}  // namespace
}  // namespace impostor::testing
