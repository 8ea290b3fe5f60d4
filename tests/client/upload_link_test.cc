// The SDK's upload (client/transfer/blob_upload.h) against the real AssetService
// (server/rpc/asset_service.cc over a BlobStore) through links that are slow,
// that stop, or that the caller gives up on. Uploads used to have a deadline
// on the whole stream, rpc_timeout_seconds plus a second per 256 KiB, so a
// slow uplink failed a large upload that was moving, as DEADLINE_EXCEEDED
// that read like the server's fault.
//
// Time enters only where it is the subject (a stall is "nothing moved for
// rpc_timeout_seconds"); every wait for an event is a condition.
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>
#include <thread>

#include <grpc/grpc.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "client/transfer/blob_upload.h"
#include "client/transfer/mesh_upload.h"
#include "client/transport/retry.h"
#include "client/transport/transport.h"
#include "common/util/sha256.h"
#include "impostor/client.h"
#include "server/blobs/blob_store.h"
#include "server/rpc/services.h"
#include "tests/client/throttled_link.h"
#include "tests/support/tcp_proxy.h"

namespace impostor::sdk {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// The deadline uploads had: rpc_timeout_seconds + one second per 256 KiB.
double OldDeadlineSeconds(double rpc_timeout_seconds, int64_t bytes) {
  return rpc_timeout_seconds + static_cast<double>(bytes) / (256 * 1024);
}

// gRPC stays initialised for the whole binary. A test that leaves a
// connection cut mid-write leaves gRPC's executor in a poll of up to 10 s,
// and the grpc_shutdown that the test's last server or channel would run
// then waits it out: 10 s more for a test that took one.
class GrpcForTheWholeBinary : public ::testing::Environment {
 public:
  void SetUp() override { grpc_init(); }
};
::testing::Environment* const kGrpc = ::testing::AddGlobalTestEnvironment(new GrpcForTheWholeBinary);

// A real AssetService over a BlobStore in a temporary folder, the file to
// upload (WriteBlob) and the count of UploadBlob streams started.
class UploadLinkTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("impostor_upload_link_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    auto store = BlobStore::Open(dir_ / "store");
    ASSERT_TRUE(store.ok()) << store.status();
    store_ = std::move(*store);
    service_ = std::make_unique<AssetServiceImpl>(store_.get(), /*scheduler=*/nullptr);
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port_);
    builder.RegisterService(service_.get());
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
  }

  void TearDown() override {
    if (server_ != nullptr) server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
    fs::remove_all(dir_);
  }

  std::string ServerAddress() const { return "127.0.0.1:" + std::to_string(port_); }

  // Writes a file of `size` patterned bytes; returns its digest.
  v1::Digest WriteBlob(size_t size) {
    std::string bytes(size, '\0');
    for (size_t i = 0; i < size; ++i) bytes[i] = static_cast<char>((i * 131) ^ (i >> 10));
    std::ofstream(blob_path(), std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(size));
    v1::Digest digest;
    digest.set_hash(Sha256Hex(bytes));
    digest.set_size_bytes(static_cast<int64_t>(size));
    return digest;
  }

  fs::path blob_path() const { return dir_ / "blob.bin"; }

  bool Stored(const v1::Digest& digest) const { return store_->Contains({digest.hash(), digest.size_bytes()}); }

  // A transport through `address` that tries each call once.
  std::unique_ptr<Transport> Connect(const std::string& address, double rpc_timeout_seconds) {
    ClientOptions options;
    options.server = address;
    options.rpc_timeout_seconds = rpc_timeout_seconds;
    options.max_attempts = 1;
    options.max_outage_seconds = 0;
    TransportHooks hooks;
    hooks.on_rpc = [this](const std::string& method) {
      std::lock_guard lock(mu_);
      if (method == "/impostor.v1.AssetService/UploadBlob") ++upload_streams_;
    };
    auto transport = Transport::Connect(options, hooks);
    EXPECT_TRUE(transport.ok()) << transport.status();
    return transport.ok() ? std::move(*transport) : nullptr;
  }

  int upload_streams() {
    std::lock_guard lock(mu_);
    return upload_streams_;
  }

  fs::path dir_;
  std::unique_ptr<BlobStore> store_;
  std::unique_ptr<AssetServiceImpl> service_;
  int port_ = 0;
  std::unique_ptr<grpc::Server> server_;
  std::mutex mu_;
  int upload_streams_ = 0;
};

// The old deadline (2 s + 512 KiB / 256 KiB/s = 4 s) expired halfway
// through this 8 s upload although every second moved 64 KiB; a 1 MiB model
// over a 12 KB/s uplink failed the same way at the default 30 s (cut after
// 34 s, 92 s now), only slower.
TEST_F(UploadLinkTest, ASlowUplinkThatKeepsMovingCompletesInOneStream) {
  const v1::Digest digest = WriteBlob(512 << 10);
  constexpr int64_t kBytesPerSecond = 64 << 10;
  constexpr double kRpcTimeout = 2;
  testing::ThrottledLink link(ServerAddress(), kBytesPerSecond);
  auto transport = Connect(link.address(), kRpcTimeout);
  ASSERT_NE(transport, nullptr);

  const Clock::time_point start = Clock::now();
  const absl::Status status = UploadBlobFile(*transport, blob_path(), digest);
  const double took = SecondsSince(start);
  ASSERT_TRUE(status.ok()) << status << " after " << took << " s";
  EXPECT_TRUE(Stored(digest)) << "the server's store has the blob under its digest";
  EXPECT_GT(took, OldDeadlineSeconds(kRpcTimeout, digest.size_bytes()))
      << "the link was fast enough for the old deadline: the test proves nothing";
  EXPECT_EQ(upload_streams(), 1) << "one stream, never cut and started over";
  EXPECT_GE(link.bytes_to_server(), digest.size_bytes());
}

// A link that stops carrying anything: the upload ends after about
// rpc_timeout_seconds, saying so, instead of waiting out a deadline that
// grows with the blob (1.5 s + 8 MiB / 256 KiB/s = 33.5 s here). The blob is
// larger than the client's kernel could take in (4 MiB), so the link's stop
// is seen while messages are still being handed to it.
TEST_F(UploadLinkTest, AStoppedUplinkFailsAfterTheStallTimeSayingTheLinkStalled) {
  const v1::Digest digest = WriteBlob(8 << 20);
  constexpr double kRpcTimeout = 1.5;
  testing::TcpProxy proxy(ServerAddress());
  auto transport = Connect(proxy.address(), kRpcTimeout);
  ASSERT_NE(transport, nullptr);
  proxy.FreezeAfter(300'000, testing::TcpProxy::Direction::kToServer);

  const Clock::time_point start = Clock::now();
  const absl::Status status = UploadBlobFile(*transport, blob_path(), digest);
  const double took = SecondsSince(start);
  EXPECT_EQ(status.code(), absl::StatusCode::kDeadlineExceeded) << status;
  const std::string message(status.message());
  EXPECT_NE(message.find("the link stalled"), std::string::npos) << message;
  EXPECT_NE(message.find("it took nothing for 1.5 s (rpc_timeout_seconds)"), std::string::npos) << message;
  EXPECT_NE(message.find(" of the blob's 8388608 bytes sent"), std::string::npos) << message;
  EXPECT_GE(took, kRpcTimeout);
  EXPECT_LT(took, kRpcTimeout + 2) << "gave up " << took << " s after the start; the link stopped at once";
  EXPECT_FALSE(Stored(digest));
  proxy.CutAll();
}

// A link that stops once the client's kernel has taken the whole blob: the
// bytes still on their way cannot be seen (the server answers only once it
// has them all), so the answer is awaited rpc_timeout_seconds per message
// the link may hold, plus one; then the upload ends, saying so.
TEST_F(UploadLinkTest, AnUplinkThatStopsAfterTheLastMessageFailsSayingTheLinkStalled) {
  const v1::Digest digest = WriteBlob(32 << 10);  // one message
  constexpr double kRpcTimeout = 0.5;
  testing::TcpProxy proxy(ServerAddress());
  auto transport = Connect(proxy.address(), kRpcTimeout);
  ASSERT_NE(transport, nullptr);
  proxy.FreezeAfter(1000, testing::TcpProxy::Direction::kToServer);

  const Clock::time_point start = Clock::now();
  const absl::Status status = UploadBlobFile(*transport, blob_path(), digest);
  const double took = SecondsSince(start);
  EXPECT_EQ(status.code(), absl::StatusCode::kDeadlineExceeded) << status;
  const std::string message(status.message());
  EXPECT_NE(message.find("the link stalled: no answer for 1 s (rpc_timeout_seconds, 0.5 s, times the 1 message(s) "
                         "the link may have held, plus one) after all 32768 bytes of the blob were sent"),
            std::string::npos)
      << message;
  EXPECT_GE(took, 2 * kRpcTimeout);
  EXPECT_LT(took, 2 * kRpcTimeout + 2);
  EXPECT_FALSE(Stored(digest));
  proxy.CutAll();
}

// Cancel() from another thread ends an upload whose link stopped, long
// before the stall watchdog (30 s) would, with the source's CANCELLED. The
// blob is larger than the client's kernel takes in, so a message is on its
// way when the cancel comes (gRPC completes it only when the connection
// gives up, ~10 s later: the caller must not wait for that).
TEST_F(UploadLinkTest, CancelEndsAnUploadInFlightPromptly) {
  const v1::Digest digest = WriteBlob(8 << 20);
  testing::TcpProxy proxy(ServerAddress());
  auto transport = Connect(proxy.address(), /*rpc_timeout_seconds=*/30);
  ASSERT_NE(transport, nullptr);
  proxy.FreezeAfter(300'000, testing::TcpProxy::Direction::kToServer);

  CancelSource cancel("the upload was given up (test)");
  std::mutex mu;
  std::condition_variable done_cv;
  bool done = false;
  absl::Status status;
  Clock::time_point returned;
  std::thread uploader([&] {
    absl::Status s = UploadBlobFile(*transport, blob_path(), digest, &cancel);
    std::lock_guard lock(mu);
    status = std::move(s);
    returned = Clock::now();
    done = true;
    done_cv.notify_all();
  });
  ASSERT_TRUE(proxy.WaitFrozen(std::chrono::seconds(20))) << "the upload never got going";
  const Clock::time_point cancelled = Clock::now();
  cancel.Cancel();
  bool ended;
  {
    std::unique_lock lock(mu);
    ended = done_cv.wait_for(lock, std::chrono::seconds(10), [&] { return done; });
  }
  if (!ended) proxy.CutAll();  // lets the thread end so that the test can report
  uploader.join();
  ASSERT_TRUE(ended) << "the upload went on after Cancel()";
  EXPECT_EQ(status.code(), absl::StatusCode::kCancelled) << status;
  EXPECT_EQ(status.message(), "the upload was given up (test)");
  EXPECT_LT(std::chrono::duration<double>(returned - cancelled).count(), 1.0);
  EXPECT_EQ(upload_streams(), 1) << "a cancelled upload is not started over";
  proxy.CutAll();
}

// The same through UploadMesh, as Client::SubmitBake calls it: a model on a
// slow uplink is uploaded, and the stats say so.
TEST_F(UploadLinkTest, UploadMeshOnASlowUplinkUploadsTheModel) {
  const v1::Digest digest = WriteBlob(384 << 10);  // 6 s; the old deadline: 3.5 s
  constexpr double kRpcTimeout = 2;
  testing::ThrottledLink link(ServerAddress(), 64 << 10);
  auto transport = Connect(link.address(), kRpcTimeout);
  ASSERT_NE(transport, nullptr);
  MeshFiles files;
  files.entry = blob_path();
  files.entry_name = "blob.bin";

  const Clock::time_point start = Clock::now();
  absl::StatusOr<UploadedMesh> uploaded = UploadMesh(*transport, files);
  const double took = SecondsSince(start);
  ASSERT_TRUE(uploaded.ok()) << uploaded.status() << " after " << took << " s";
  EXPECT_EQ(uploaded->stats.uploaded, 1);
  EXPECT_EQ(uploaded->stats.bytes_uploaded, digest.size_bytes());
  EXPECT_EQ(uploaded->mesh.entry().digest().hash(), digest.hash());
  EXPECT_TRUE(Stored(digest));
  EXPECT_GT(took, OldDeadlineSeconds(kRpcTimeout, digest.size_bytes()));
}

}  // namespace
}  // namespace impostor::sdk
