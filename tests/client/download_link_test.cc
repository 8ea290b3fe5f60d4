// The SDK's download against the real AssetService (server/rpc/asset_service.cc
// over a BlobStore) through a TCP proxy that cuts the link mid-stream: what a
// cut costs is set by the server's ReadBlob message size, since the client
// keeps whole messages only. The tester's proxy cut links every ~17 s at
// 8 KB/s; with 1 MiB messages nothing was ever kept.
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <string>
#include <thread>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "client/transfer/blob_download.h"
#include "client/transport/transport.h"
#include "common/util/sha256.h"
#include "impostor/client.h"
#include "server/blobs/blob_store.h"
#include "server/rpc/services.h"
#include "tests/support/tcp_proxy.h"

namespace impostor::sdk {
namespace {

namespace fs = std::filesystem;

TEST(DownloadLink, ACutLinkCostsAtMostOneServerMessageAndTheDownloadResumes) {
  const fs::path dir = fs::temp_directory_path() / ("impostor_download_link_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  auto store = BlobStore::Open(dir);
  ASSERT_TRUE(store.ok()) << store.status();
  std::string blob((1 << 20) + 12345, '\0');
  for (size_t i = 0; i < blob.size(); ++i) blob[i] = static_cast<char>((i * 131) ^ (i >> 10));
  const BlobDigest stored{Sha256Hex(blob), static_cast<int64_t>(blob.size())};
  ASSERT_TRUE((*store)->Put(stored, blob).ok());
  AssetServiceImpl service(store->get(), /*scheduler=*/nullptr);  // ReadBlob needs the blobs only
  int port = 0;
  grpc::ServerBuilder builder;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(&service);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  ASSERT_NE(server, nullptr);
  testing::TcpProxy proxy("127.0.0.1:" + std::to_string(port));

  std::mutex mu;
  std::condition_variable changed;
  int read_blobs = 0;
  std::string got;
  TransportHooks hooks;
  hooks.on_rpc = [&](const std::string& method) {
    std::lock_guard lock(mu);
    if (method == "/impostor.v1.AssetService/ReadBlob") ++read_blobs;
  };
  ClientOptions options;
  options.server = proxy.address();
  options.max_attempts = 2;
  options.max_outage_seconds = 0;
  auto transport = Transport::Connect(options, hooks);
  ASSERT_TRUE(transport.ok()) << transport.status();

  // The link carries 300 000 bytes of the stream, then nothing: room for
  // four whole 64 KiB messages (a 1 MiB one never completes).
  proxy.FreezeAfter(300'000, testing::TcpProxy::Direction::kToClient);
  v1::Digest digest;
  digest.set_hash(stored.hash);
  digest.set_size_bytes(stored.size_bytes);
  absl::Status result;
  std::thread downloader([&] {
    result = DownloadBlob(**transport, digest, [&](std::string_view data) {
      std::lock_guard lock(mu);
      got.append(data);
      changed.notify_all();
      return absl::OkStatus();
    });
  });
  constexpr size_t kKeptAtLeast = 3 * 64 * 1024;  // three whole messages; four fit
  bool kept;
  {
    std::unique_lock lock(mu);
    kept = changed.wait_for(lock, std::chrono::seconds(20), [&] { return got.size() >= kKeptAtLeast; });
  }
  EXPECT_TRUE(kept) << "bytes kept before the cut: " << got.size() << " of the 300000 that crossed the link";
  EXPECT_TRUE(proxy.WaitFrozen(std::chrono::seconds(20)));
  size_t before_cut;
  {
    std::lock_guard lock(mu);
    before_cut = got.size();
  }
  proxy.CutAll();  // the stream breaks; the download resumes at before_cut
  downloader.join();
  ASSERT_TRUE(result.ok()) << result;
  std::lock_guard lock(mu);
  EXPECT_TRUE(got == blob) << "got " << got.size() << " bytes";
  EXPECT_EQ(read_blobs, 2) << "one stream cut, one resumed after " << before_cut << " bytes";
  server->Shutdown();
  fs::remove_all(dir);
}

}  // namespace
}  // namespace impostor::sdk
