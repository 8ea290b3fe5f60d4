// Resumable uploads (issue 44): the real AssetService over a BlobStore in a
// temporary folder keeps what a broken UploadBlob stream brought, QueryUpload
// says how much, and a stream whose first message carries that offset sends
// only the rest, verified on completion as a fresh upload. The SDK's upload
// (client/transfer/blob_upload.h) cut at 50 % by tests/support/tcp_proxy
// resumes, sending at most the remaining bytes plus one message.
//
// A partial is made deterministic by a client that half-closes its stream
// early: the server answers only once it has kept the bytes, so no test
// waits for time to pass.
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
#include "client/transport/transport.h"
#include "common/util/sha256.h"
#include "impostor/client.h"
#include "server/blobs/blob_store.h"
#include "server/rpc/services.h"
#include "tests/support/tcp_proxy.h"

namespace impostor::sdk {
namespace {

namespace fs = std::filesystem;

// gRPC stays initialised for the whole binary (see upload_link_test.cc: a
// connection cut mid-write otherwise costs the last shutdown 10 s).
class GrpcForTheWholeBinary : public ::testing::Environment {
 public:
  void SetUp() override { grpc_init(); }
};
::testing::Environment* const kGrpc = ::testing::AddGlobalTestEnvironment(new GrpcForTheWholeBinary);

// Patterned bytes that differ at every position of a message.
std::string Pattern(size_t size, int seed) {
  std::string bytes(size, '\0');
  for (size_t i = 0; i < size; ++i) bytes[i] = static_cast<char>((i * 131 + seed) ^ (i >> 10));
  return bytes;
}

// What TCP carries beside a blob's bytes: HTTP/2 frame headers and gRPC
// message framing (about 45 bytes a 64 KiB message, 0.07 %), a new
// connection's preface and settings, each call's headers, QueryUpload.
int64_t FramingAllowance(int64_t blob_bytes) { return blob_bytes / 1000 + 2048; }

// Waits until the server's store holds at least `bytes` of `digest`'s
// upload (the progress of a stream it is still reading): polled, since the
// store announces no progress; false when `timeout` passes first. What
// crossed a link reaches the server's handler only as fast as it reads it,
// so a cut "at 50 %" is made once the server has read 50 %.
bool WaitUntilServerHolds(BlobStore& store, const v1::Digest& digest, int64_t bytes, std::chrono::seconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    absl::StatusOr<int64_t> held = store.PartialBytes({digest.hash(), digest.size_bytes()});
    if (held.ok() && *held >= bytes) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return false;
}

v1::Digest DigestOf(const std::string& bytes) {
  v1::Digest digest;
  digest.set_hash(Sha256Hex(bytes));
  digest.set_size_bytes(static_cast<int64_t>(bytes.size()));
  return digest;
}

class UploadResumeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("impostor_upload_resume_" + std::to_string(::getpid()) + "_" +
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
    stub_ = v1::AssetService::NewStub(grpc::CreateChannel(ServerAddress(), grpc::InsecureChannelCredentials()));
  }

  void TearDown() override {
    if (server_ != nullptr) server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
    fs::remove_all(dir_);
  }

  std::string ServerAddress() const { return "127.0.0.1:" + std::to_string(port_); }

  // One raw UploadBlob stream: `bytes` from the blob's byte `offset`, in
  // 64 KiB messages, then a half-close.
  grpc::Status Stream(const v1::Digest& digest, int64_t offset, std::string_view bytes) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
    v1::UploadBlobResponse response;
    auto writer = stub_->UploadBlob(&ctx, &response);
    v1::UploadBlobRequest message;
    *message.mutable_digest() = digest;
    message.set_offset(offset);
    bool first = true;
    while (first || !bytes.empty()) {
      const size_t n = std::min<size_t>(bytes.size(), kUploadChunkBytes);
      message.set_data(bytes.data(), n);
      bytes.remove_prefix(n);
      if (!writer->Write(message)) break;
      message.clear_digest();
      message.clear_offset();
      first = false;
    }
    writer->WritesDone();
    return writer->Finish();
  }

  v1::QueryUploadResponse Query(const v1::Digest& digest, grpc::Status* status_out = nullptr) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
    v1::QueryUploadRequest request;
    *request.mutable_digest() = digest;
    v1::QueryUploadResponse response;
    const grpc::Status status = stub_->QueryUpload(&ctx, request, &response);
    if (status_out != nullptr) *status_out = status;
    EXPECT_TRUE(status_out != nullptr || status.ok()) << status.error_message();
    return response;
  }

  bool Stored(const v1::Digest& digest) const { return store_->Contains({digest.hash(), digest.size_bytes()}); }

  fs::path dir_;
  std::unique_ptr<BlobStore> store_;
  std::unique_ptr<AssetServiceImpl> service_;
  int port_ = 0;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<v1::AssetService::Stub> stub_;
};

TEST_F(UploadResumeTest, AStreamEndedEarlyIsKeptAndAResumeSendsOnlyTheRest) {
  const std::string blob = Pattern(1 << 20, 1);
  const v1::Digest digest = DigestOf(blob);
  const int64_t half = digest.size_bytes() / 2;

  const grpc::Status cut = Stream(digest, 0, std::string_view(blob).substr(0, half));
  EXPECT_EQ(cut.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << cut.error_message();
  EXPECT_NE(cut.error_message().find("ended after 524288 of its 1048576 bytes"), std::string::npos)
      << cut.error_message();
  const v1::QueryUploadResponse kept = Query(digest);
  EXPECT_EQ(kept.committed_bytes(), half);
  EXPECT_FALSE(kept.complete());
  EXPECT_FALSE(Stored(digest));

  const grpc::Status resumed = Stream(digest, half, std::string_view(blob).substr(half));
  ASSERT_TRUE(resumed.ok()) << resumed.error_message();
  EXPECT_TRUE(Stored(digest));
  EXPECT_EQ(*store_->ReadAll({digest.hash(), digest.size_bytes()}), blob);
  const v1::QueryUploadResponse done = Query(digest);
  EXPECT_TRUE(done.complete());
  EXPECT_EQ(store_->kept_partial_bytes(), 0) << "the resumed partial became the blob";
}

// The bytes sent after the kept ones are not the blob's: refused as a
// fresh upload's would be, and the partial is gone (a retry starts over).
TEST_F(UploadResumeTest, ACorruptResumeIsRefusedAndDropsThePartial) {
  const std::string blob = Pattern(1 << 20, 2);
  const v1::Digest digest = DigestOf(blob);
  const int64_t half = digest.size_bytes() / 2;
  ASSERT_EQ(Stream(digest, 0, std::string_view(blob).substr(0, half)).error_code(),
            grpc::StatusCode::INVALID_ARGUMENT);
  ASSERT_EQ(Query(digest).committed_bytes(), half);

  std::string rest = blob.substr(half);
  rest[rest.size() / 2] ^= 0x5a;
  const grpc::Status corrupt = Stream(digest, half, rest);
  EXPECT_EQ(corrupt.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << corrupt.error_message();
  EXPECT_NE(corrupt.error_message().find("hash mismatch"), std::string::npos) << corrupt.error_message();
  EXPECT_FALSE(Stored(digest));
  EXPECT_EQ(Query(digest).committed_bytes(), 0) << "a corrupt resume leaves no partial behind";
  EXPECT_EQ(store_->kept_partial_bytes(), 0);
}

// A kept prefix that was itself wrong (the client's file changed between
// tries) is caught on completion too: the whole blob is hashed.
TEST_F(UploadResumeTest, AResumeAfterAWrongPrefixIsRefused) {
  const std::string blob = Pattern(1 << 20, 3);
  const v1::Digest digest = DigestOf(blob);
  const int64_t half = digest.size_bytes() / 2;
  std::string wrong_prefix = blob.substr(0, half);
  wrong_prefix[10] ^= 1;
  ASSERT_EQ(Stream(digest, 0, wrong_prefix).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  const grpc::Status status = Stream(digest, half, std::string_view(blob).substr(half));
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_FALSE(Stored(digest));
}

TEST_F(UploadResumeTest, AnOffsetThatIsNotTheKeptLengthIsAFailedPreconditionNamingBoth) {
  const std::string blob = Pattern(1 << 20, 4);
  const v1::Digest digest = DigestOf(blob);
  const int64_t kept = 3 * int64_t{kUploadChunkBytes};  // 196608
  ASSERT_EQ(Stream(digest, 0, std::string_view(blob).substr(0, kept)).error_code(),
            grpc::StatusCode::INVALID_ARGUMENT);
  struct Case {
    const char* name;
    int64_t offset;
  } cases[] = {{"past the kept bytes", kept + 1000}, {"short of the kept bytes", kept - 1000}};
  for (const Case& c : cases) {
    const grpc::Status status = Stream(digest, c.offset, std::string_view(blob).substr(c.offset));
    EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << c.name << ": " << status.error_message();
    EXPECT_NE(status.error_message().find(std::to_string(c.offset)), std::string::npos)
        << c.name << ": " << status.error_message();
    EXPECT_NE(status.error_message().find("(196608 bytes)"), std::string::npos) << c.name << ": "
                                                                                << status.error_message();
    EXPECT_EQ(Query(digest).committed_bytes(), kept) << c.name << ": a refused offset leaves the partial as it was";
  }
  // Nothing kept at all: the message says 0.
  const std::string other = Pattern(1 << 20, 5);
  const grpc::Status none = Stream(DigestOf(other), 4096, std::string_view(other).substr(4096));
  EXPECT_EQ(none.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << none.error_message();
  EXPECT_NE(none.error_message().find("offset: 4096 is not the length"), std::string::npos) << none.error_message();
  EXPECT_NE(none.error_message().find("(0 bytes)"), std::string::npos) << none.error_message();
}

// Offset 0 starts afresh: the kept partial is dropped, the upload stored.
TEST_F(UploadResumeTest, OffsetZeroDiscardsTheKeptPartial) {
  const std::string blob = Pattern(512 << 10, 6);
  const v1::Digest digest = DigestOf(blob);
  ASSERT_EQ(Stream(digest, 0, std::string_view(blob).substr(0, 128 << 10)).error_code(),
            grpc::StatusCode::INVALID_ARGUMENT);
  ASSERT_EQ(store_->kept_partial_bytes(), 128 << 10);
  const grpc::Status fresh = Stream(digest, 0, blob);
  ASSERT_TRUE(fresh.ok()) << fresh.error_message();
  EXPECT_TRUE(Stored(digest));
  EXPECT_EQ(store_->kept_partial_bytes(), 0);
}

TEST_F(UploadResumeTest, QueryUploadRefusesAMissingOrMalformedDigest) {
  struct Case {
    const char* name;
    bool has_digest;
    std::string hash;
    int64_t size;
  } cases[] = {
      {"no digest", false, "", 0},
      {"short hash", true, "abc", 10},
      {"upper-case hash", true, std::string(64, 'A'), 10},
      {"negative size", true, std::string(64, 'a'), -1},
  };
  for (const Case& c : cases) {
    grpc::ClientContext ctx;
    v1::QueryUploadRequest request;
    if (c.has_digest) {
      request.mutable_digest()->set_hash(c.hash);
      request.mutable_digest()->set_size_bytes(c.size);
    }
    v1::QueryUploadResponse response;
    const grpc::Status status = stub_->QueryUpload(&ctx, request, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << c.name << ": " << status.error_message();
    EXPECT_NE(status.error_message().find("digest"), std::string::npos) << c.name << ": " << status.error_message();
  }
  // A well-formed digest the server knows nothing of: 0, not complete.
  const v1::QueryUploadResponse unknown = Query(DigestOf("never uploaded"));
  EXPECT_EQ(unknown.committed_bytes(), 0);
  EXPECT_FALSE(unknown.complete());
}

// The SDK's upload cut at 50 % by the link: the link lets a little more
// than half the blob through and freezes, and once the server has read half
// of it the link is cut (both ends see the connection close). The retry
// asks (QueryUpload) and sends only the rest: on the wire (TCP payload to
// the server after the cut, framing and the question included) at most the
// remaining half plus one message, where starting over would send the
// whole blob again.
TEST_F(UploadResumeTest, AnSdkUploadCutAtHalfResumesSendingAtMostTheRestPlusOneMessage) {
  const std::string blob = Pattern(8 << 20, 7);
  const v1::Digest digest = DigestOf(blob);
  const fs::path path = dir_ / "blob.bin";
  std::ofstream(path, std::ios::binary).write(blob.data(), static_cast<std::streamsize>(blob.size()));
  testing::TcpProxy proxy(ServerAddress());
  ClientOptions options;
  options.server = proxy.address();
  options.rpc_timeout_seconds = 30;
  options.max_attempts = 3;
  options.max_outage_seconds = 0;
  auto transport = Transport::Connect(options);
  ASSERT_TRUE(transport.ok()) << transport.status();
  const int64_t connected = proxy.bytes_forwarded(testing::TcpProxy::Direction::kToServer);
  const int64_t half = digest.size_bytes() / 2;
  const int64_t chunk = static_cast<int64_t>(kUploadChunkBytes);
  proxy.FreezeAfter(half + chunk + FramingAllowance(half), testing::TcpProxy::Direction::kToServer);

  absl::Status status;
  std::thread uploader([&] { status = UploadBlobFile(**transport, path, digest); });
  const bool frozen = proxy.WaitFrozen(std::chrono::seconds(30));
  const bool held = frozen && WaitUntilServerHolds(*store_, digest, half, std::chrono::seconds(30));
  const int64_t before_cut = proxy.bytes_forwarded(testing::TcpProxy::Direction::kToServer) - connected;
  proxy.CutAll();
  uploader.join();
  ASSERT_TRUE(frozen) << "the upload never reached half way";
  ASSERT_TRUE(held) << "the server never read half the blob";
  ASSERT_TRUE(status.ok()) << status;
  EXPECT_TRUE(Stored(digest));
  EXPECT_EQ(*store_->ReadAll({digest.hash(), digest.size_bytes()}), blob);

  const int64_t after_cut =
      proxy.bytes_forwarded(testing::TcpProxy::Direction::kToServer) - connected - before_cut;
  const int64_t bound = (digest.size_bytes() - half) + chunk;
  EXPECT_LE(after_cut, bound) << "sent " << after_cut << " bytes after a cut at half of " << digest.size_bytes()
                              << ": more than the rest plus one message";
  EXPECT_GE(after_cut, digest.size_bytes() - before_cut) << "the rest of the blob went somewhere else?";
}

// A blob the server has already: the SDK's question says so and no stream
// is opened.
TEST_F(UploadResumeTest, AnSdkUploadOfAStoredBlobSendsNothing) {
  const std::string blob = Pattern(256 << 10, 8);
  const v1::Digest digest = DigestOf(blob);
  ASSERT_TRUE(Stream(digest, 0, blob).ok());
  const fs::path path = dir_ / "blob.bin";
  std::ofstream(path, std::ios::binary).write(blob.data(), static_cast<std::streamsize>(blob.size()));
  ClientOptions options;
  options.server = ServerAddress();
  int streams = 0;
  TransportHooks hooks;
  hooks.on_rpc = [&](const std::string& method) { streams += method == "/impostor.v1.AssetService/UploadBlob"; };
  auto transport = Transport::Connect(options, hooks);
  ASSERT_TRUE(transport.ok()) << transport.status();
  const absl::Status status = UploadBlobFile(**transport, path, digest);
  ASSERT_TRUE(status.ok()) << status;
  EXPECT_EQ(streams, 0);
}

}  // namespace
}  // namespace impostor::sdk
