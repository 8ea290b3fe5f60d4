// StampBakedBy (server/scheduler/manifest_stamp.h) on what a hostile worker token can
// upload as manifest.json: deep nesting is refused before anything deep is
// built (120 KB of brackets crashed the server on the stack), and the stored
// text never grows far past what was uploaded (indentation inflated 60 KB to
// 1.8 GB).
#include "server/scheduler/manifest_stamp.h"

#include <unistd.h>

#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "common/util/sha256.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

class ManifestStampTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("manifest_stamp_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    blobs_ = std::move(*BlobStore::Open(dir_));
  }
  void TearDown() override { fs::remove_all(dir_); }
  v1::Digest Upload(const std::string& text) {
    v1::Digest d;
    d.set_hash(Sha256Hex(text));
    d.set_size_bytes(static_cast<int64_t>(text.size()));
    EXPECT_TRUE(blobs_->Put({d.hash(), d.size_bytes()}, text).ok());
    return d;
  }
  fs::path dir_;
  std::unique_ptr<BlobStore> blobs_;
};

TEST_F(ManifestStampTest, AnOrdinaryManifestIsStampedAndKeptReadable) {
  const std::string text = R"({"cache_key": "k", "views": [{"dir": [0, 1, 0]}], "baked_by": "a forgery"})";
  auto stamped = StampBakedBy(*blobs_, Upload(text), "render-node-1");
  ASSERT_TRUE(stamped.ok()) << stamped.status();
  auto bytes = blobs_->ReadAll({stamped->hash(), stamped->size_bytes()});
  ASSERT_TRUE(bytes.ok());
  const auto j = nlohmann::json::parse(*bytes);
  EXPECT_EQ(j["baked_by"], "render-node-1") << "the server's word, not the worker's";
  EXPECT_EQ(j["views"][0]["dir"][1], 1);
  EXPECT_NE(bytes->find("\n  \"cache_key\""), std::string::npos) << "indented for people";
}

TEST_F(ManifestStampTest, DeepNestingIsRefusedNamingTheFieldAndTheLimit) {
  for (const int depth : {33, 3000, 100000}) {
    const std::string text = "{\"a\":" + std::string(depth, '[') + std::string(depth, ']') + "}";
    auto stamped = StampBakedBy(*blobs_, Upload(text), "w");
    EXPECT_EQ(stamped.status().code(), absl::StatusCode::kInvalidArgument) << depth;
    EXPECT_NE(stamped.status().message().find("result.manifest_json: nested deeper than 32 levels"),
              std::string::npos)
        << stamped.status();
  }
  const std::string ok = "{\"a\":" + std::string(30, '[') + std::string(30, ']') + "}";
  EXPECT_TRUE(StampBakedBy(*blobs_, Upload(ok), "w").ok());
}

TEST_F(ManifestStampTest, ASmallDeepManifestIsNotInflatedEither) {
  // 200 KB, 31 levels down: indentation alone would make it ~30 times larger.
  std::string text = "{\"a\":" + std::string(30, '[');
  while (text.size() < (200 << 10)) text += "0,";
  text += "0" + std::string(30, ']') + "}";
  auto stamped = StampBakedBy(*blobs_, Upload(text), "w");
  ASSERT_TRUE(stamped.ok()) << stamped.status();
  EXPECT_LT(stamped->size_bytes(), static_cast<int64_t>(text.size()) + 1024);
}

TEST_F(ManifestStampTest, ALargeManifestIsStoredCompactNotInflated) {
  // 2 MB of small numbers 30 levels down: indented, each would take ~60 bytes.
  std::string text = "{\"a\":" + std::string(29, '[') + "[";
  while (text.size() < (2 << 20)) text += "1,";
  text += "1]" + std::string(29, ']') + "}";
  auto stamped = StampBakedBy(*blobs_, Upload(text), "w");
  ASSERT_TRUE(stamped.ok()) << stamped.status();
  EXPECT_LT(stamped->size_bytes(), static_cast<int64_t>(text.size()) + 1024);
}

}  // namespace
}  // namespace impostor
