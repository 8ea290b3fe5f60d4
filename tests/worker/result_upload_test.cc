// The worker's result upload (worker/result_upload.h) against the real
// AssetService over a BlobStore: a try cut at 50 % by the link leaves the
// server a partial, and the next try (the worker loop's retry) sends only
// the rest; a link that takes nothing is cut by the stall watchdog, not by
// a deadline on the whole stream.
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include <grpc/grpc.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "common/net/keepalive.h"
#include "common/util/sha256.h"
#include "server/blobs/blob_store.h"
#include "server/rpc/services.h"
#include "tests/support/tcp_proxy.h"
#include "worker/result_upload.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// What TCP carries beside a blob's bytes: HTTP/2 frame headers and gRPC
// message framing (about 45 bytes a 64 KiB message, 0.07 %), a new
// connection's preface and settings, each call's headers, QueryUpload.
int64_t FramingAllowance(int64_t blob_bytes) { return blob_bytes / 1000 + 2048; }

// Waits until the server's store holds at least `bytes` of `digest`'s
// upload (the progress of a stream it is still reading): polled, since the
// store announces no progress; false when `timeout` passes first. A cut
// "at 50 %" is made once the server has read 50 %.
bool WaitUntilServerHolds(BlobStore& store, const v1::Digest& digest, int64_t bytes, std::chrono::seconds timeout) {
  const auto end = Clock::now() + timeout;
  while (Clock::now() < end) {
    absl::StatusOr<int64_t> held = store.PartialBytes({digest.hash(), digest.size_bytes()});
    if (held.ok() && *held >= bytes) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return false;
}

class GrpcForTheWholeBinary : public ::testing::Environment {
 public:
  void SetUp() override { grpc_init(); }
};
::testing::Environment* const kGrpc = ::testing::AddGlobalTestEnvironment(new GrpcForTheWholeBinary);

class ResultUploadTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("impostor_result_upload_" + std::to_string(::getpid()) + "_" +
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

  // A result file of `size` patterned bytes; its digest.
  v1::Digest WriteResult(size_t size) {
    std::string bytes(size, '\0');
    for (size_t i = 0; i < size; ++i) bytes[i] = static_cast<char>((i * 197) ^ (i >> 9));
    std::ofstream(path(), std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(size));
    bytes_ = bytes;
    v1::Digest digest;
    digest.set_hash(Sha256Hex(bytes));
    digest.set_size_bytes(static_cast<int64_t>(size));
    return digest;
  }
  fs::path path() const { return dir_ / "atlas.png"; }
  bool Stored(const v1::Digest& d) const { return store_->Contains({d.hash(), d.size_bytes()}); }

  fs::path dir_;
  std::string bytes_;  // the result file's
  std::unique_ptr<BlobStore> store_;
  std::unique_ptr<AssetServiceImpl> service_;
  int port_ = 0;
  std::unique_ptr<grpc::Server> server_;
};

TEST_F(ResultUploadTest, ATryCutAtHalfIsResumedByTheNextSendingAtMostTheRestPlusOneMessage) {
  const v1::Digest digest = WriteResult(8 << 20);
  const ResultUploadOptions options;
  const int64_t chunk = static_cast<int64_t>(options.chunk_bytes);
  testing::TcpProxy proxy(ServerAddress());
  v1::AssetService::Stub stub(grpc::CreateChannel(proxy.address(), grpc::InsecureChannelCredentials()));
  const int64_t half = digest.size_bytes() / 2;
  proxy.FreezeAfter(half + chunk + FramingAllowance(half), testing::TcpProxy::Direction::kToServer);

  absl::Status first;
  int64_t first_sent = 0;
  std::thread uploader([&] { first = UploadResultFile(stub, path(), digest, options, &first_sent); });
  const bool frozen = proxy.WaitFrozen(std::chrono::seconds(30));
  const bool held = frozen && WaitUntilServerHolds(*store_, digest, half, std::chrono::seconds(30));
  const int64_t before_cut = proxy.bytes_forwarded(testing::TcpProxy::Direction::kToServer);
  proxy.CutAll();
  uploader.join();
  ASSERT_TRUE(frozen) << "the upload never reached half way";
  ASSERT_TRUE(held) << "the server never read half the blob";
  ASSERT_FALSE(first.ok()) << "the cut try cannot have stored the blob";
  EXPECT_EQ(first.code(), absl::StatusCode::kUnavailable) << first;
  EXPECT_FALSE(Stored(digest));

  // The worker loop tries again (RetryThroughOutage): this call.
  int64_t second_sent = 0;
  const absl::Status second = UploadResultFile(stub, path(), digest, options, &second_sent);
  ASSERT_TRUE(second.ok()) << second;
  EXPECT_TRUE(Stored(digest));
  EXPECT_EQ(*store_->ReadAll({digest.hash(), digest.size_bytes()}), bytes_);
  EXPECT_LE(second_sent, digest.size_bytes() - half) << "the second try sent " << second_sent
                                                      << " blob bytes after a cut at half of " << digest.size_bytes();
  EXPECT_GE(second_sent, digest.size_bytes() - before_cut);
  const int64_t wire_after = proxy.bytes_forwarded(testing::TcpProxy::Direction::kToServer) - before_cut;
  EXPECT_LE(wire_after, digest.size_bytes() - half + chunk) << "on the wire, framing and the question included";
}

// No deadline on the stream: a link that keeps moving is not cut however
// long it takes; one that takes nothing is cut after the stall limit,
// saying so, and what it took is kept for the next try.
TEST_F(ResultUploadTest, AStoppedLinkIsCutByTheStallWatchdogAndItsBytesAreKept) {
  const v1::Digest digest = WriteResult(8 << 20);
  ResultUploadOptions options;
  options.stall_limit = std::chrono::milliseconds(1500);
  testing::TcpProxy proxy(ServerAddress());
  // As the worker's channel: keepalive, so that a write the stopped link
  // never takes returns once the connection is given up (gRPC completes no
  // step of a cancelled call before that; result_upload.h).
  constexpr int kKeepaliveSeconds = 3;  // longer than the stall limit: the watchdog ends it
  grpc::ChannelArguments args;
  ApplyClientKeepalive(kKeepaliveSeconds, args);
  v1::AssetService::Stub stub(
      grpc::CreateCustomChannel(proxy.address(), grpc::InsecureChannelCredentials(), args));
  proxy.FreezeAfter(1 << 20, testing::TcpProxy::Direction::kToServer);

  const Clock::time_point start = Clock::now();
  const absl::Status status = UploadResultFile(stub, path(), digest, options);
  const double took = std::chrono::duration<double>(Clock::now() - start).count();
  EXPECT_EQ(status.code(), absl::StatusCode::kDeadlineExceeded) << status;
  EXPECT_NE(status.message().find("the link stalled"), std::string::npos) << status;
  EXPECT_GE(took, 1.5);
  EXPECT_LT(took, 1.5 + kKeepaliveSeconds + KeepaliveTimeoutSeconds(kKeepaliveSeconds) + 3)
      << "the watchdog and the keepalive, not a deadline, ended it";
  proxy.CutAll();
  const absl::Status resumed = UploadResultFile(stub, path(), digest, options);
  ASSERT_TRUE(resumed.ok()) << resumed;
  EXPECT_TRUE(Stored(digest));
}

}  // namespace
}  // namespace impostor
