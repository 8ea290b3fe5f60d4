// AssetService.BatchUpdateBlobs against a real impostor-server (issue 45):
// many small blobs stored in one call, each verified against its digest as
// an UploadBlob is and answered in the request's order with its own code (a
// forged blob is refused in its slot, the others stored); a bad request is
// refused whole, naming the field and the limit, and stores nothing; the
// token's upload quota counts a batch's bytes.
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/net/batch_read.h"
#include "common/util/sha256.h"
#include "tests/support/published_result.h"
#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

struct Blob {
  v1::Digest digest;
  std::string data;
};

Blob BlobOf(const std::string& data) { return {DigestOf(data), data}; }

grpc::Status BatchUpdate(v1::AssetService::Stub& assets, const std::vector<Blob>& blobs,
                         v1::BatchUpdateBlobsResponse* response, const std::string& authorization = "") {
  auto ctx = ContextWithAuthorization(authorization);
  v1::BatchUpdateBlobsRequest request;
  for (const Blob& blob : blobs) {
    v1::BatchUpdateBlobsRequest::Request* r = request.add_requests();
    *r->mutable_digest() = blob.digest;
    r->set_data(blob.data);
  }
  return assets.BatchUpdateBlobs(ctx.get(), request, response);
}

// The blob's bytes as ReadBlob streams them; "" after failing the test.
std::string ReadBack(ServerProcess& server, const v1::Digest& digest) {
  auto ctx = ContextWithin();
  v1::ReadBlobRequest request;
  *request.mutable_digest() = digest;
  auto reader = server.assets().ReadBlob(ctx.get(), request);
  std::string bytes;
  v1::ReadBlobResponse chunk;
  while (reader->Read(&chunk)) bytes += chunk.data();
  const grpc::Status s = reader->Finish();
  EXPECT_TRUE(s.ok()) << digest.hash() << ": " << s.error_message();
  return bytes;
}

bool Stored(ServerProcess& server, const v1::Digest& digest) {
  auto ctx = ContextWithin();
  v1::FindMissingBlobsRequest request;
  *request.add_digests() = digest;
  v1::FindMissingBlobsResponse response;
  const grpc::Status s = server.assets().FindMissingBlobs(ctx.get(), request, &response);
  EXPECT_TRUE(s.ok()) << s.error_message();
  return s.ok() && response.missing_size() == 0;
}

TEST(BatchUpdate, EveryBlobIsStoredAndReadBlobGivesItsBytes) {
  ServerProcess server(/*local_workers=*/0);
  std::vector<Blob> blobs;
  for (uint32_t seed = 1; seed <= 5; ++seed) blobs.push_back(BlobOf(RandomBytes(1000 * seed, seed)));
  blobs.push_back(BlobOf(""));
  const Blob present = BlobOf(RandomBytes(700, 77));
  ASSERT_TRUE(UploadBytes(server.assets(), present.data, present.digest).ok());
  blobs.push_back(present);

  v1::BatchUpdateBlobsResponse response;
  const grpc::Status s = BatchUpdate(server.assets(), blobs, &response);
  ASSERT_TRUE(s.ok()) << s.error_message();
  ASSERT_EQ(response.responses_size(), static_cast<int>(blobs.size()));
  for (size_t i = 0; i < blobs.size(); ++i) {
    const v1::BatchUpdateBlobsResponse::Response& r = response.responses(static_cast<int>(i));
    EXPECT_EQ(r.code(), 0) << i << ": " << r.message();
    EXPECT_EQ(r.digest().hash(), blobs[i].digest.hash()) << i;
    EXPECT_EQ(r.digest().size_bytes(), blobs[i].digest.size_bytes()) << i;
    EXPECT_EQ(r.already_present(), i == blobs.size() - 1) << i;
    EXPECT_EQ(ReadBack(server, blobs[i].digest), blobs[i].data) << i;
  }
  // Nothing sent, nothing answered.
  v1::BatchUpdateBlobsResponse none;
  ASSERT_TRUE(BatchUpdate(server.assets(), {}, &none).ok());
  EXPECT_EQ(none.responses_size(), 0);
}

// One bad blob does not fail the others: each is answered in its slot.
TEST(BatchUpdate, AForgedBlobIsRefusedNamingItsIndexAndBothDigestsWhileTheOthersAreStored) {
  ServerProcess server(/*local_workers=*/0);
  std::vector<Blob> blobs;
  for (uint32_t seed = 1; seed <= 5; ++seed) blobs.push_back(BlobOf(RandomBytes(2000 + seed, seed)));
  // [1]: one byte changed, same size; [3]: a byte short.
  const std::string flipped = [&] {
    std::string d = blobs[1].data;
    d[100] = static_cast<char>(d[100] ^ 0x20);
    return d;
  }();
  blobs[1].data = flipped;
  const std::string shorter = blobs[3].data.substr(1);
  blobs[3].data = shorter;
  // [5]: other bytes under the digest of a blob the store has.
  const Blob present = BlobOf(RandomBytes(900, 55));
  ASSERT_TRUE(UploadBytes(server.assets(), present.data, present.digest).ok());
  const std::string impostor = RandomBytes(900, 56);
  blobs.push_back({present.digest, impostor});

  v1::BatchUpdateBlobsResponse response;
  const grpc::Status s = BatchUpdate(server.assets(), blobs, &response);
  ASSERT_TRUE(s.ok()) << s.error_message();
  ASSERT_EQ(response.responses_size(), 6);
  struct Refusal {
    int index;
    std::vector<std::string> message_has;
  };
  for (const Refusal& r : {Refusal{1, {"requests[1]", blobs[1].digest.hash(), Sha256Hex(flipped)}},
                           Refusal{3, {"requests[3]", blobs[3].digest.hash(), Sha256Hex(shorter),
                                       std::to_string(blobs[3].digest.size_bytes()),
                                       std::to_string(shorter.size())}},
                           Refusal{5, {"requests[5]", present.digest.hash(), Sha256Hex(impostor)}}}) {
    const v1::BatchUpdateBlobsResponse::Response& answer = response.responses(r.index);
    EXPECT_EQ(answer.code(), static_cast<int>(grpc::StatusCode::INVALID_ARGUMENT)) << r.index << ": " << answer.message();
    for (const std::string& part : r.message_has) {
      EXPECT_NE(answer.message().find(part), std::string::npos) << r.index << ": " << answer.message();
    }
    if (r.index != 5) EXPECT_FALSE(Stored(server, blobs[r.index].digest)) << r.index;
    EXPECT_FALSE(Stored(server, DigestOf(blobs[r.index].data))) << r.index << ": stored under its own hash";
  }
  EXPECT_EQ(ReadBack(server, present.digest), present.data) << "the stored blob is untouched";
  for (int i : {0, 2, 4}) {
    EXPECT_EQ(response.responses(i).code(), 0) << i << ": " << response.responses(i).message();
    EXPECT_EQ(ReadBack(server, blobs[i].digest), blobs[i].data) << i;
  }
}

TEST(BatchUpdate, BadRequestsAreRefusedWholeNamingTheFieldAndTheLimitAndStoreNothing) {
  ServerProcess server(/*local_workers=*/0);
  const Blob good = BlobOf(RandomBytes(100, 7));
  const Blob big = BlobOf(RandomBytes(kMaxBatchUpdateBytes - 150, 8));
  const Blob over = BlobOf(RandomBytes(151, 9));
  Blob bad_hash = good;
  bad_hash.digest.set_hash("XYZ");
  Blob negative = good;
  negative.digest.set_size_bytes(-1);
  struct Case {
    const char* name;
    std::vector<Blob> blobs;
    std::vector<const char*> message_has;
    bool drop_digest = false;  // of the last blob
  };
  const std::vector<Case> cases = {
      {"over 1,000 blobs", std::vector<Blob>(kMaxBatchUpdateBlobs + 1, good), {"requests: 1001", "1000"}},
      {"a malformed hash", {good, good, bad_hash}, {"requests[2].digest.hash", "64 lowercase hex"}},
      {"a negative size", {good, negative}, {"requests[1].digest.size_bytes", ">= 0"}},
      {"no digest", {good, good}, {"requests[1].digest: required"}, true},
      {"data over 4 MiB together", {good, big, over}, {"requests[2].data", "4194304", "UploadBlob"}},
  };
  for (const Case& c : cases) {
    auto ctx = ContextWithin();
    v1::BatchUpdateBlobsRequest request;
    for (const Blob& blob : c.blobs) {
      v1::BatchUpdateBlobsRequest::Request* r = request.add_requests();
      *r->mutable_digest() = blob.digest;
      r->set_data(blob.data);
    }
    if (c.drop_digest) request.mutable_requests(request.requests_size() - 1)->clear_digest();
    v1::BatchUpdateBlobsResponse response;
    const grpc::Status s = server.assets().BatchUpdateBlobs(ctx.get(), request, &response);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << c.name << ": " << s.error_message();
    for (const char* part : c.message_has) {
      EXPECT_NE(s.error_message().find(part), std::string::npos) << c.name << ": " << s.error_message();
    }
    EXPECT_EQ(response.responses_size(), 0) << c.name;
    EXPECT_FALSE(Stored(server, good.digest)) << c.name << ": a refused request stored its good blob";
  }
  // At the limits exactly: 1,000 blobs, and data of 4 MiB together.
  v1::BatchUpdateBlobsResponse response;
  ASSERT_TRUE(BatchUpdate(server.assets(), std::vector<Blob>(kMaxBatchUpdateBlobs, good), &response).ok());
  EXPECT_EQ(response.responses_size(), kMaxBatchUpdateBlobs);
  const Blob rest = BlobOf(RandomBytes(50, 10));
  const grpc::Status s = BatchUpdate(server.assets(), {good, big, rest}, &response);
  ASSERT_TRUE(s.ok()) << s.error_message();
  ASSERT_EQ(response.responses_size(), 3);
  EXPECT_EQ(response.responses(1).code(), 0) << response.responses(1).message();
  EXPECT_EQ(ReadBack(server, big.digest), big.data);
}

// The daily upload quota is UploadBlob's: checked as the call starts (a
// refused batch stores nothing), charged the bytes the batch stored.
TEST(BatchUpdate, TheTokensUploadQuotaCountsABatchsBytes) {
  ServerProcess server(0, {"--auth=token", "--token-max-upload-bytes-per-day=1000"});
  const std::string uploader = "Bearer " + CreateToken(server.data_dir(), "submitter", "uploader");
  v1::BatchUpdateBlobsResponse response;
  ASSERT_TRUE(
      BatchUpdate(server.assets(), {BlobOf(RandomBytes(600, 1)), BlobOf(RandomBytes(600, 2))}, &response, uploader)
          .ok());
  ASSERT_EQ(response.responses_size(), 2);
  EXPECT_EQ(response.responses(1).code(), 0) << response.responses(1).message();

  auto ctx = ContextWithAuthorization(uploader);
  v1::BatchUpdateBlobsRequest request;
  const Blob late = BlobOf(RandomBytes(10, 3));
  *request.add_requests()->mutable_digest() = late.digest;
  request.mutable_requests(0)->set_data(late.data);
  v1::BatchUpdateBlobsResponse refused;
  const grpc::Status s = server.assets().BatchUpdateBlobs(ctx.get(), request, &refused);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
  EXPECT_NE(s.error_message().find("uploads of token 'uploader': 1200 bytes in the last 24 hours"), std::string::npos)
      << s.error_message();
  const auto& trailers = ctx->GetServerTrailingMetadata();
  const auto reason = trailers.find("impostor-error-reason");
  ASSERT_NE(reason, trailers.end());
  EXPECT_EQ(std::string(reason->second.data(), reason->second.size()), "TOKEN_UPLOAD_BYTES_PER_DAY");
  EXPECT_EQ(refused.responses_size(), 0);
}

}  // namespace
}  // namespace impostor::testing
