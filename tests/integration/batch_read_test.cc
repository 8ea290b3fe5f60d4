// AssetService.BatchReadBlobs against a real impostor-server (issue 45):
// many small blobs in one call, each answered in the request's order with
// its bytes or its own code, checked against its digest as a whole ReadBlob
// is; a bad request is refused whole, naming the field and the limit.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/net/batch_read.h"
#include "tests/support/published_result.h"
#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;

grpc::Status BatchRead(ServerProcess& server, const std::vector<v1::Digest>& digests,
                       v1::BatchReadBlobsResponse* response) {
  auto ctx = ContextWithin();
  v1::BatchReadBlobsRequest request;
  for (const v1::Digest& d : digests) *request.add_digests() = d;
  return server.assets().BatchReadBlobs(ctx.get(), request, response);
}

v1::Digest Forged(const std::string& hash, int64_t size) {
  v1::Digest d;
  d.set_hash(hash);
  d.set_size_bytes(size);
  return d;
}

TEST(BatchRead, EachBlobIsAnsweredInOrderWithItsBytesOrItsOwnCode) {
  ServerProcess server(/*local_workers=*/0);
  std::vector<std::string> bytes;
  std::vector<v1::Digest> digests;
  for (uint32_t seed = 1; seed <= 5; ++seed) {
    bytes.push_back(RandomBytes(1000 * seed, seed));
    digests.push_back(DigestOf(bytes.back()));
    ASSERT_TRUE(UploadBytes(server.assets(), bytes.back(), digests.back()).ok());
  }
  // An empty blob, a blob never uploaded, and one damaged on disk.
  bytes.push_back("");
  digests.push_back(DigestOf(""));
  ASSERT_TRUE(UploadBytes(server.assets(), "", digests.back()).ok());
  const v1::Digest never = DigestOf(RandomBytes(300, 99));
  const fs::path damaged = server.data_dir() / "cas" / digests[2].hash().substr(0, 2) / digests[2].hash();
  fs::permissions(damaged, fs::perms::owner_write, fs::perm_options::add);
  {
    std::fstream io(damaged, std::ios::in | std::ios::out | std::ios::binary);
    io.seekp(10);
    io.put(static_cast<char>(bytes[2][10] ^ 0x01));
  }
  const std::vector<v1::Digest> asked = {digests[4], never, digests[0], digests[2], digests[5], digests[1]};
  v1::BatchReadBlobsResponse response;
  const grpc::Status s = BatchRead(server, asked, &response);
  ASSERT_TRUE(s.ok()) << s.error_message();
  ASSERT_EQ(response.blobs_size(), 6);
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(response.blobs(i).digest().hash(), asked[i].hash()) << i;
    EXPECT_EQ(response.blobs(i).digest().size_bytes(), asked[i].size_bytes()) << i;
  }
  EXPECT_EQ(response.blobs(0).code(), 0);
  EXPECT_EQ(response.blobs(0).data(), bytes[4]);
  EXPECT_EQ(response.blobs(1).code(), static_cast<int>(grpc::StatusCode::NOT_FOUND)) << response.blobs(1).message();
  EXPECT_TRUE(response.blobs(1).data().empty());
  EXPECT_EQ(response.blobs(2).data(), bytes[0]);
  // The damaged blob: DATA_LOSS, no bytes, and quarantined (now missing).
  EXPECT_EQ(response.blobs(3).code(), static_cast<int>(grpc::StatusCode::DATA_LOSS)) << response.blobs(3).message();
  EXPECT_NE(response.blobs(3).message().find(digests[2].hash()), std::string::npos) << response.blobs(3).message();
  EXPECT_TRUE(response.blobs(3).data().empty());
  EXPECT_FALSE(fs::exists(damaged));
  EXPECT_EQ(response.blobs(4).code(), 0);
  EXPECT_TRUE(response.blobs(4).data().empty());
  EXPECT_EQ(response.blobs(5).data(), bytes[1]);
  // Nothing asked, nothing answered.
  v1::BatchReadBlobsResponse none;
  ASSERT_TRUE(BatchRead(server, {}, &none).ok());
  EXPECT_EQ(none.blobs_size(), 0);
}

TEST(BatchRead, BadRequestsAreRefusedWholeNamingTheFieldAndTheLimit) {
  ServerProcess server(/*local_workers=*/0);
  const std::string small = RandomBytes(100, 7);
  const v1::Digest good = DigestOf(small);
  ASSERT_TRUE(UploadBytes(server.assets(), small, good).ok());
  const std::string hash(64, 'a');
  struct Case {
    const char* name;
    std::vector<v1::Digest> digests;
    std::vector<const char*> message_has;
  };
  const std::vector<Case> cases = {
      {"over 1,000 digests", std::vector<v1::Digest>(kMaxBatchReadDigests + 1, good), {"digests: 1001", "1000"}},
      {"a malformed hash", {good, good, Forged("XYZ", 3)}, {"digests[2].hash", "64 lowercase hex"}},
      {"a negative size", {good, Forged(hash, -1)}, {"digests[1].size_bytes", ">= 0"}},
      {"sizes over 4 MiB together",
       {good, Forged(hash, kMaxBatchReadBytes - 150), Forged(hash, 100)},
       {"digests[2].size_bytes", "4194304", "ReadBlob"}},
      // A forged size near the largest int64 must not wrap the sum.
      {"a size that would wrap",
       {good, Forged(hash, std::numeric_limits<int64_t>::max())},
       {"digests[1].size_bytes", "4194304"}},
  };
  for (const Case& c : cases) {
    v1::BatchReadBlobsResponse response;
    const grpc::Status s = BatchRead(server, c.digests, &response);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << c.name << ": " << s.error_message();
    for (const char* part : c.message_has) {
      EXPECT_NE(s.error_message().find(part), std::string::npos) << c.name << ": " << s.error_message();
    }
    EXPECT_EQ(response.blobs_size(), 0) << c.name;
  }
  // At the limits exactly: 1,000 digests, and sizes of 4 MiB together.
  v1::BatchReadBlobsResponse response;
  ASSERT_TRUE(BatchRead(server, std::vector<v1::Digest>(kMaxBatchReadDigests, good), &response).ok());
  EXPECT_EQ(response.blobs_size(), kMaxBatchReadDigests);
  const std::string four_mib = RandomBytes(kMaxBatchReadBytes - 100, 8);
  const v1::Digest big = DigestOf(four_mib);
  ASSERT_TRUE(UploadBytes(server.assets(), four_mib, big).ok());
  ASSERT_TRUE(BatchRead(server, {good, big}, &response).ok());
  ASSERT_EQ(response.blobs_size(), 2);
  EXPECT_EQ(response.blobs(1).data(), four_mib);
}

}  // namespace
}  // namespace impostor::testing
