// The release format's pure pieces (client/delivery): names, paths, the
// catalog and channel files read back from untrusted bytes, Ed25519
// signatures, the publisher's inputs, and the download coordinator's
// prefetch priorities and cancellation.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <future>
#include <mutex>
#include <string>
#include <vector>

#include "client/cache/download_coordinator.h"
#include "client/delivery/catalog.h"
#include "client/delivery/catalog_signature.h"
#include "client/delivery/publisher.h"
#include "client/delivery/release_paths.h"
#include "common/util/sha256.h"
#include "nlohmann/json.hpp"

namespace impostor::delivery {
namespace {

namespace fs = std::filesystem;

const std::string kHexA(64, 'a');
const std::string kHexB(64, 'b');
const std::string kHexC(64, 'c');

TEST(ReleaseNames, AssetNames) {
  struct Case {
    const char* name;
    bool ok;
    const char* says;
  };
  const std::string long_name(201, 'x');
  const std::vector<Case> cases = {
      {"trees/oak", true, ""},
      {"rocks/granite_01.lod-2", true, ""},
      {"a", true, ""},
      {"", false, "must not be empty"},
      {"../etc/passwd", false, ". or .. segment"},
      {"trees/../../x", false, ". or .. segment"},
      {"trees/./oak", false, ". or .. segment"},
      {"/abs/path", false, "must not start with /"},
      {"trees/", false, "must not end with /"},
      {"trees//oak", false, "empty segment"},
      {"trees\\oak", false, "only letters"},
      {"tree oak", false, "only letters"},
      {"tr%2e%2e", false, "only letters"},
      {"ünicode", false, "only letters"},
  };
  for (const Case& c : cases) {
    absl::Status s = ValidateAssetName(c.name);
    EXPECT_EQ(s.ok(), c.ok) << "case \"" << c.name << "\": " << s;
    if (!c.ok) {
      EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << c.name;
      EXPECT_NE(s.message().find(c.says), absl::string_view::npos) << "case \"" << c.name << "\": " << s;
    }
  }
  absl::Status too_long = ValidateAssetName(long_name);
  EXPECT_NE(too_long.message().find("limit is 200"), absl::string_view::npos) << too_long;
  EXPECT_TRUE(ValidateAssetName(std::string(200, 'x')).ok());
}

TEST(ReleaseNames, ChannelNames) {
  for (const char* ok : {"nightly", "release-1.4", "R2_beta", "0"}) {
    EXPECT_TRUE(ValidateChannelName(ok).ok()) << ok;
  }
  for (const char* bad : {"", ".hidden", "-x", "a/b", "../x", "sp ace", "x.json/.."}) {
    absl::Status s = ValidateChannelName(bad);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << "channel \"" << bad << "\"";
  }
  EXPECT_FALSE(ValidateChannelName(std::string(65, 'a')).ok());
  EXPECT_TRUE(ValidateChannelName(std::string(64, 'a')).ok());
}

TEST(ReleaseNames, PathsAndMediaTypes) {
  EXPECT_EQ(BlobPath(kHexA), "v1/blobs/sha256/aa/" + kHexA);
  EXPECT_EQ(CatalogPath(kHexB), "v1/catalogs/sha256/bb/" + kHexB);
  EXPECT_EQ(ChannelPath("nightly"), "v1/channels/nightly.json");
  EXPECT_EQ(JoinUrl("http://cdn/x/", "/v1/a"), "http://cdn/x/v1/a");
  EXPECT_EQ(JoinUrl("http://cdn/x", "v1/a"), "http://cdn/x/v1/a");
  EXPECT_EQ(MediaTypeForFile("albedo_alpha.png"), "image/png");
  EXPECT_EQ(MediaTypeForFile("orm.KTX2"), "image/ktx2");
  EXPECT_EQ(MediaTypeForFile("manifest.json"), "application/json");
  EXPECT_EQ(MediaTypeForFile("lod1.glb"), "model/gltf-binary");
  EXPECT_EQ(MediaTypeForFile("surfels.bin"), "application/octet-stream");
  EXPECT_TRUE(IsQualityViewSemantic("quality_view_mesh"));
  EXPECT_TRUE(IsQualityViewSemantic("contact_sheet"));
  EXPECT_FALSE(IsQualityViewSemantic("albedo_alpha"));
}

v1::Manifest SampleManifest() {
  v1::Manifest m;
  m.set_cache_key(kHexA);
  m.set_baker_version("0.2.0-bake5");
  m.set_layout(v1::LAYOUT_HEMI_OCTAHEDRAL);
  m.set_product(v1::PRODUCT_ATLAS);
  m.set_frames(12);
  m.set_resolution(2048);
  auto add = [&](const char* semantic, const char* file, const std::string& hex, int64_t size) {
    v1::MapFile* map = m.add_maps();
    map->set_semantic(semantic);
    map->set_file(file);
    map->mutable_digest()->set_hash(hex);
    map->mutable_digest()->set_size_bytes(size);
    map->set_width(2048);
    map->set_height(2048);
    map->set_format("png_rgba8");
  };
  add("albedo_alpha", "albedo_alpha.png", kHexB, 100);
  add("contact_sheet", "contact_sheet.png", kHexC, 50);
  add("quality_view_mesh", "view_00_mesh.png", kHexC, 50);
  m.mutable_manifest_json()->set_hash(std::string(64, 'd'));
  m.mutable_manifest_json()->set_size_bytes(7);
  return m;
}

TEST(Catalog, AssetFromManifestLeavesQualityViewsOut) {
  absl::StatusOr<CatalogAsset> asset = AssetFromManifest(SampleManifest(), /*include_quality_views=*/false);
  ASSERT_TRUE(asset.ok()) << asset.status();
  ASSERT_EQ(asset->files.size(), 2u);
  EXPECT_EQ(asset->files[0].name, "albedo_alpha.png");
  EXPECT_EQ(asset->files[0].media_type, "image/png");
  EXPECT_EQ(asset->files[1].name, "manifest.json");
  EXPECT_EQ(asset->layout, "hemi-octahedral");
  EXPECT_EQ(asset->product, "atlas");
  absl::StatusOr<CatalogAsset> all = AssetFromManifest(SampleManifest(), /*include_quality_views=*/true);
  ASSERT_TRUE(all.ok());
  EXPECT_EQ(all->files.size(), 4u);

  v1::Manifest bad = SampleManifest();
  bad.mutable_maps(0)->set_file("../escape.png");
  EXPECT_EQ(AssetFromManifest(bad, false).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(Catalog, RoundTripIsCanonical) {
  Catalog c;
  c.created_at = "2026-12-02T01:02:03Z";
  c.baker_version = "0.2.0-bake5";
  c.assets["trees/oak"] = *AssetFromManifest(SampleManifest(), false);
  c.assets["rocks/a"] = *AssetFromManifest(SampleManifest(), false);
  const std::string text = CatalogToJson(c);
  absl::StatusOr<Catalog> back = ParseCatalog(text, "test");
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->assets, c.assets);
  EXPECT_EQ(CatalogToJson(*back), text) << "same content, same bytes, same digest";
  // The listing the cache installs from carries the same files.
  v1::Manifest listing = ManifestFromAsset(back->assets.at("trees/oak"));
  EXPECT_EQ(listing.cache_key(), kHexA);
  EXPECT_EQ(listing.layout(), v1::LAYOUT_HEMI_OCTAHEDRAL);
  ASSERT_EQ(listing.maps_size(), 1);
  EXPECT_EQ(listing.maps(0).file(), "albedo_alpha.png");
  EXPECT_EQ(listing.manifest_json().hash(), std::string(64, 'd'));
}

TEST(Catalog, RefusesBadDocuments) {
  Catalog c;
  c.created_at = "x";
  c.assets["trees/oak"] = *AssetFromManifest(SampleManifest(), false);
  const std::string good = CatalogToJson(c);
  auto with = [&](const std::string& from, const std::string& to) {
    std::string s = good;
    const size_t at = s.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return s.replace(at, from.size(), to);
  };
  struct Case {
    const char* what;
    std::string text;
    absl::StatusCode code;
    const char* says;
  };
  const std::vector<Case> cases = {
      {"html page", "<html><body>502 Bad Gateway</body></html>", absl::StatusCode::kInvalidArgument, "HTML"},
      {"empty", "", absl::StatusCode::kInvalidArgument, "not a JSON object"},
      {"other schema", with("\"impostor-catalog\"", "\"something\""), absl::StatusCode::kInvalidArgument, "schema"},
      {"newer version", with("\"schema_version\":1", "\"schema_version\":7"), absl::StatusCode::kFailedPrecondition,
       "newer than this reader's"},
      {"bad key", with("\"cache_key\":\"" + kHexA, "\"cache_key\":\"XYZ"), absl::StatusCode::kInvalidArgument,
       "cache_key must be 64 lowercase hex"},
      {"traversal file", with("\"albedo_alpha.png\"", "\"../../etc/passwd\""), absl::StatusCode::kInvalidArgument,
       "plain file name"},
      {"hidden file", with("\"albedo_alpha.png\"", "\".entry\""), absl::StatusCode::kInvalidArgument,
       "plain file name"},
      {"traversal name", with("\"trees/oak\"", "\"../oak\""), absl::StatusCode::kInvalidArgument, ". or .."},
      {"negative size", with("\"size_bytes\":100", "\"size_bytes\":-5"), absl::StatusCode::kInvalidArgument,
       "size_bytes must be a whole number"},
      {"no manifest", with("\"manifest.json\"", "\"other.json\""), absl::StatusCode::kInvalidArgument,
       "must list manifest.json"},
      // The assets come before "schema" in the text; a reader that does not
      // know the schema says so, not what it makes of the assets.
      {"newer version, bad asset",
       [&] {
         std::string both = with("\"cache_key\":\"" + kHexA, "\"cache_key\":\"XYZ");
         return both.replace(both.find("\"schema_version\":1"), 18, "\"schema_version\":7");
       }(),
       absl::StatusCode::kFailedPrecondition, "newer than this reader's"},
      {"asset twice",
       with("\"assets\":{", "\"assets\":{\"trees/oak\":" + nlohmann::json::parse(good)["assets"]["trees/oak"].dump() + ","),
       absl::StatusCode::kInvalidArgument,
       "assets[\"trees/oak\"] is listed twice"},
      {"asset not an object", with("\"assets\":{", "\"assets\":{\"rocks/a\":7,"), absl::StatusCode::kInvalidArgument,
       "assets[\"rocks/a\"]. must be an object"},
      {"assets not an object", "{\"schema\":\"impostor-catalog\",\"schema_version\":1,\"created_at\":\"x\","
                               "\"baker_version\":\"\",\"assets\":[]}",
       absl::StatusCode::kInvalidArgument, "assets must be an object"},
      {"cut short", good.substr(0, good.size() / 2), absl::StatusCode::kInvalidArgument, "not a JSON object"},
  };
  for (const Case& c : cases) {
    absl::StatusOr<Catalog> parsed = ParseCatalog(c.text, "mirror-x");
    EXPECT_EQ(parsed.status().code(), c.code) << c.what << ": " << parsed.status();
    EXPECT_NE(parsed.status().message().find(c.says), absl::string_view::npos) << c.what << ": " << parsed.status();
    EXPECT_NE(parsed.status().message().find("mirror-x"), absl::string_view::npos) << c.what;
  }
}

TEST(Channel, RoundTripAndRefusals) {
  ChannelPointer p;
  p.channel = "nightly";
  p.catalog_sha256 = kHexB;
  p.catalog_size_bytes = 42;
  p.published_at = "2026-12-02T00:00:00Z";
  absl::StatusOr<ChannelPointer> back = ParseChannel(ChannelToJson(p), "c");
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->catalog_sha256, kHexB);
  EXPECT_EQ(back->catalog_size_bytes, 42);
  EXPECT_FALSE(back->signature.has_value());
  p.channel = "../x";
  EXPECT_EQ(ParseChannel(ChannelToJson(p), "c").status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ParseChannel("{\"schema\":\"impostor-channel\",\"schema_version\":1}", "c").status().code(),
            absl::StatusCode::kInvalidArgument);
  // A catalog a reader would have to hold whole: refused before a byte of it is fetched.
  p.channel = "nightly";
  p.catalog_size_bytes = kMaxCatalogBytes;
  EXPECT_TRUE(ParseChannel(ChannelToJson(p), "c").ok()) << "the limit itself is accepted";
  p.catalog_size_bytes = kMaxCatalogBytes + 1;
  absl::StatusOr<ChannelPointer> huge = ParseChannel(ChannelToJson(p), "c");
  EXPECT_EQ(huge.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(huge.status().message().find("catalog.size_bytes 268435457 is over the limit of 268435456 bytes"),
            absl::string_view::npos)
      << huge.status();
}

// Ed25519 keys made by the openssl CLI, as an operator makes them.
class SignatureTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("impostor-sig-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    for (const char* name : {"a", "b"}) {
      const std::string key = (dir_ / (std::string(name) + ".pem")).string();
      const std::string pub = (dir_ / (std::string(name) + ".pub")).string();
      ASSERT_EQ(std::system(("openssl genpkey -algorithm ed25519 -out " + key + " 2>/dev/null").c_str()), 0);
      ASSERT_EQ(std::system(("openssl pkey -in " + key + " -pubout -out " + pub + " 2>/dev/null").c_str()), 0);
    }
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(SignatureTest, SignsAndVerifies) {
  const std::string catalog = "{\"assets\":{}}";
  absl::StatusOr<CatalogSignature> sig = SignCatalog(dir_ / "a.pem", catalog);
  ASSERT_TRUE(sig.ok()) << sig.status();
  absl::StatusOr<CatalogPublicKey> a = LoadCatalogPublicKey(dir_ / "a.pub");
  absl::StatusOr<CatalogPublicKey> b = LoadCatalogPublicKey(dir_ / "b.pub");
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(sig->key_id, a->key_id);
  EXPECT_TRUE(VerifyCatalog(*a, *sig, catalog, "src").ok());
  // Tampered bytes, another key, no signature: all refused.
  EXPECT_EQ(VerifyCatalog(*a, *sig, catalog + " ", "src").code(), absl::StatusCode::kPermissionDenied);
  absl::Status other = VerifyCatalog(*b, *sig, catalog, "src");
  EXPECT_EQ(other.code(), absl::StatusCode::kPermissionDenied);
  EXPECT_NE(other.message().find("trusts key"), absl::string_view::npos) << other;
  EXPECT_EQ(VerifyCatalog(*a, std::nullopt, catalog, "src").code(), absl::StatusCode::kPermissionDenied);
  CatalogSignature garbled = *sig;
  garbled.value = "not base64!";
  EXPECT_EQ(VerifyCatalog(*a, garbled, catalog, "src").code(), absl::StatusCode::kPermissionDenied);
  // A public key where a private one belongs, and a missing file.
  EXPECT_EQ(SignCatalog(dir_ / "a.pub", catalog).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(LoadCatalogPublicKey(dir_ / "missing.pub").status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(PublishInputs, Arguments) {
  absl::StatusOr<std::vector<PublishEntry>> e = EntriesFromArguments({kHexA, "trees/oak=" + kHexB});
  ASSERT_TRUE(e.ok()) << e.status();
  ASSERT_EQ(e->size(), 2u);
  EXPECT_EQ((*e)[0], (PublishEntry{kHexA, kHexA}));
  EXPECT_EQ((*e)[1], (PublishEntry{"trees/oak", kHexB}));
  EXPECT_EQ(EntriesFromArguments({"trees/oak=nothex"}).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(EntriesFromArguments({"../x=" + kHexA}).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(EntriesFromArguments({"oak"}).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(PublishInputs, BatchReport) {
  const std::string report =
      "{\"type\":\"asset\",\"asset\":\"models/oak.glb\",\"name\":\"oak\",\"status\":\"succeeded\",\"cache_key\":\"" +
      kHexA + "\"}\n" +
      "{\"type\":\"asset\",\"asset\":\"models/Birch.gltf\",\"name\":\"\",\"status\":\"succeeded\",\"cache_key\":\"" +
      kHexB + "\"}\n" + "{\"type\":\"summary\",\"total\":2}\n";
  absl::StatusOr<std::vector<PublishEntry>> e = EntriesFromBatchReport(report, "r.json");
  ASSERT_TRUE(e.ok()) << e.status();
  ASSERT_EQ(e->size(), 2u);
  EXPECT_EQ((*e)[0], (PublishEntry{"oak", kHexA}));
  EXPECT_EQ((*e)[1], (PublishEntry{"Birch", kHexB}));

  const std::string failed =
      "{\"type\":\"asset\",\"asset\":\"x.glb\",\"name\":\"x\",\"status\":\"failed\",\"cache_key\":null}\n";
  absl::Status s = EntriesFromBatchReport(failed, "r.json").status();
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(s.message().find("\"x\""), absl::string_view::npos) << s;
  EXPECT_EQ(EntriesFromBatchReport("not json\n", "r.json").status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(EntriesFromBatchReport("{\"type\":\"summary\"}\n", "r.json").status().code(),
            absl::StatusCode::kInvalidArgument);
}

// Background flights start by priority, re-prioritised while queued, and a
// queued or running prefetch can be cancelled; a Get's flight cannot.
TEST(DownloadCoordinatorPriority, OrdersReprioritisesAndCancels) {
  std::mutex mu;
  std::vector<std::string> started;
  std::promise<void> release_gate;
  std::shared_future<void> gate = release_gate.get_future().share();
  std::promise<void> blocker_running;
  sdk::DownloadCoordinator coordinator(
      /*threads=*/1, /*max_background=*/1,
      [&](const std::string& key, sdk::CancelSource& cancel) -> sdk::DownloadCoordinator::Result {
        {
          std::lock_guard lock(mu);
          started.push_back(key);
        }
        if (key == "blocker") {
          blocker_running.set_value();
          while (gate.wait_for(std::chrono::milliseconds(5)) != std::future_status::ready) {
            if (cancel.cancelled()) return cancel.error();
          }
        }
        return absl::NotFoundError("no result in this test");
      });
  std::vector<std::promise<absl::Status>> outcomes(5);
  auto done = [&](int i) { return [&, i](sdk::DownloadCoordinator::Result r) { outcomes[i].set_value(r.status()); }; };
  coordinator.Join("blocker", false, done(0), 0);
  blocker_running.get_future().wait();  // the one pool thread is busy now
  coordinator.Join("low", false, done(1), 1);
  coordinator.Join("high", false, done(2), 5);
  coordinator.Join("dropped", false, done(3), 9);
  coordinator.Join("low", false, [](auto) {}, 10);  // re-prioritised: now first
  EXPECT_TRUE(coordinator.Cancel("dropped"));
  EXPECT_EQ(outcomes[3].get_future().get().code(), absl::StatusCode::kCancelled);
  EXPECT_FALSE(coordinator.Cancel("not-queued"));
  // The running prefetch, cancelled: it ends with CANCELLED.
  EXPECT_TRUE(coordinator.Cancel("blocker"));
  EXPECT_EQ(outcomes[0].get_future().get().code(), absl::StatusCode::kCancelled);
  EXPECT_EQ(outcomes[1].get_future().get().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(outcomes[2].get_future().get().code(), absl::StatusCode::kNotFound);
  release_gate.set_value();
  std::lock_guard lock(mu);
  EXPECT_EQ(started, (std::vector<std::string>{"blocker", "low", "high"}));
}

}  // namespace
}  // namespace impostor::delivery
