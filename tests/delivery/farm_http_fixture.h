// Test fixture shared by the farm-HTTP tests (farm_http_fetch_test.cc,
// farm_http_only_fetch_test.cc): a real impostor-server with --http-listen
// holding one published result (tests/support/published_result.h) of two
// large maps and one small, client options for it, a FaultMirror front end
// holding the same files, and checks of what a fetch installed.
#ifndef IMPOSTOR_TESTS_DELIVERY_FARM_HTTP_FIXTURE_H_
#define IMPOSTOR_TESTS_DELIVERY_FARM_HTTP_FIXTURE_H_

#include <gtest/gtest.h>

#include <atomic>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "client/transfer/result_fetch.h"
#include "client/transport/transport.h"
#include "tests/delivery/fault_mirror.h"
#include "tests/metrics/http_test_client.h"
#include "tests/support/published_result.h"
#include "tests/support/server_process.h"

namespace impostor::testing {

inline constexpr char kReadBlob[] = "/impostor.v1.AssetService/ReadBlob";
// Two maps over BatchReadBlobs' 1 MiB per blob (streamed: the front end's
// files) and one under it (batched over gRPC with manifest.json).
inline const std::vector<int64_t> kMapSizes = {1'500'000, 1'200'000, 300'000};
inline const char* const kLargeFiles[] = {"albedo_alpha.png", "normal_depth.png"};

// What the SDK logs goes to stderr; a test's own assertions do not read it.
class FarmHttpTest : public ::testing::Test {
 protected:
  void SetUp() override {
    server_ = std::make_unique<ServerProcess>(0, std::vector<std::string>{"--http-listen", "127.0.0.1:0"});
    http_url_ = "http://127.0.0.1:" + std::to_string(HttpPort(*server_));
    dir_ = NewTempDir(std::string("farm_http_") + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    result_ = PublishResult(*server_, kMapSizes, 41);
  }
  void TearDown() override {
    const std::filesystem::path data = server_->data_dir();
    server_.reset();
    std::filesystem::remove_all(data);
    std::filesystem::remove_all(dir_);
  }

  sdk::ClientOptions Options(const std::string& farm_http) {
    sdk::ClientOptions o;
    o.server = server_->address();
    o.connect_timeout_seconds = 10;
    o.rpc_timeout_seconds = 1;  // a stalled front end is left after ~1 s a try
    o.max_attempts = 2;
    o.max_outage_seconds = 0;
    o.farm_http = farm_http;
    return o;
  }

  // FetchResultFiles into a fresh folder through a transport whose RPCs
  // are counted; returns the ReadBlob streams it started (-1 on failure).
  int FetchCountingReadBlobs(const std::string& farm_http, const std::string& token = "",
                             const std::string& server = "") {
    sdk::ClientOptions o = Options(farm_http);
    o.token = token;
    if (!server.empty()) o.server = server;
    auto read_blobs = std::make_shared<std::atomic<int>>(0);
    sdk::TransportHooks hooks;
    hooks.on_rpc = [read_blobs](const std::string& method) {
      if (method == kReadBlob) read_blobs->fetch_add(1);
    };
    absl::StatusOr<std::unique_ptr<sdk::Transport>> transport = sdk::Transport::Connect(o, hooks);
    EXPECT_TRUE(transport.ok()) << transport.status();
    if (!transport.ok()) return -1;
    const std::filesystem::path out = dir_ / ("out" + std::to_string(++fetches_));
    absl::StatusOr<sdk::FetchResult> fetched = sdk::FetchResultFiles(**transport, result_.key, out, 1);
    EXPECT_TRUE(fetched.ok()) << fetched.status();
    if (!fetched.ok()) return -1;
    ExpectFilesAre(out);
    return read_blobs->load();
  }

  // `dir` holds exactly the result's maps and its manifest, byte for byte.
  void ExpectFilesAre(const std::filesystem::path& dir) {
    for (const auto& [name, bytes] : result_.files) {
      EXPECT_EQ(ReadFileBytes(dir / name), bytes) << name << " differs from what the farm holds";
    }
    int files = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir)) files += e.is_regular_file() ? 1 : 0;
    EXPECT_EQ(files, static_cast<int>(result_.files.size())) << "stray or missing files in " << dir;
  }

  // A front end in the test's hands: the large files under the URL shape
  // the SDK asks for, below the FaultMirror's /v1/ root.
  std::string MirrorFilePath(const std::string& name) const {
    return "v1/farm/api/v1/results/" + result_.key + "/files/" + name;
  }
  // The result's listing (BASE/api/v1/results/KEY/manifest) on it.
  std::string MirrorListingPath() const { return "v1/farm/api/v1/results/" + result_.key + "/manifest"; }
  // The listing as the farm answers GetResult, in protobuf's binary form.
  std::string ListingBytes() {
    absl::StatusOr<std::unique_ptr<sdk::Transport>> transport = sdk::Transport::Connect(Options("none"));
    EXPECT_TRUE(transport.ok()) << transport.status();
    if (!transport.ok()) return "";
    absl::StatusOr<v1::Manifest> manifest = (*transport)->GetResult(result_.key);
    EXPECT_TRUE(manifest.ok()) << manifest.status();
    return manifest.ok() ? manifest->SerializeAsString() : "";
  }
  // Serves the result's files and its listing; base URL front->url() + "/v1/farm".
  std::unique_ptr<FaultMirror> StartFaultyFrontEnd() {
    for (const auto& [name, bytes] : result_.files) {
      const std::filesystem::path path = dir_ / "front" / MirrorFilePath(name);
      std::filesystem::create_directories(path.parent_path());
      WriteFileBytes(path, bytes);
    }
    WriteFileBytes(dir_ / "front" / MirrorListingPath(), ListingBytes());
    return std::make_unique<FaultMirror>(dir_ / "front");
  }

  static void WriteFileBytes(const std::filesystem::path& path, const std::string& bytes) {
    FILE* f = std::fopen(path.c_str(), "wb");
    ASSERT_NE(f, nullptr) << path;
    ASSERT_EQ(std::fwrite(bytes.data(), 1, bytes.size(), f), bytes.size());
    std::fclose(f);
  }

  std::unique_ptr<ServerProcess> server_;
  std::string http_url_;
  std::filesystem::path dir_;
  PublishedResult result_;
  int fetches_ = 0;
};

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_DELIVERY_FARM_HTTP_FIXTURE_H_
