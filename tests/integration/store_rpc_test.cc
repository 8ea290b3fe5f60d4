// The store's promises over the wire, against a real impostor-server (results
// are published through WorkerService as a worker would, so no GPU is
// needed): corrupt bytes on disk answer DATA_LOSS through ReadBlob and are
// quarantined; the store cap evicts least recently used results but never a
// pinned one (PinResult) nor a young upload; per-client limits and fairness
// tell clients apart by the impostor-client-id metadata.
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <string>

#include <gtest/gtest.h>

#include "tests/support/published_result.h"
#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;

fs::path BlobFile(const ServerProcess& server, const std::string& hash) {
  return server.data_dir() / "cas" / hash.substr(0, 2) / hash;
}

bool IsMissing(ServerProcess& server, const v1::Digest& digest) {
  auto ctx = ContextWithin();
  v1::FindMissingBlobsRequest request;
  *request.add_digests() = digest;
  v1::FindMissingBlobsResponse response;
  const grpc::Status s = server.assets().FindMissingBlobs(ctx.get(), request, &response);
  EXPECT_TRUE(s.ok()) << s.error_message();
  return response.missing_size() == 1;
}

grpc::Status GetResult(ServerProcess& server, const std::string& key) {
  auto ctx = ContextWithin();
  v1::GetResultRequest request;
  request.set_cache_key(key);
  v1::Manifest manifest;
  return server.assets().GetResult(ctx.get(), request, &manifest);
}

grpc::Status Pin(ServerProcess& server, const std::string& key, bool pinned) {
  auto ctx = ContextWithin();
  v1::PinResultRequest request;
  request.set_cache_key(key);
  request.set_pinned(pinned);
  v1::PinResultResponse response;
  return server.assets().PinResult(ctx.get(), request, &response);
}

struct Damage {
  const char* name;
  bool read_first;  // served once before the damage (the verified state is cached)
  void (*apply)(const fs::path& file);
};

void FlipAByte(const fs::path& f) {
  std::fstream io(f, std::ios::in | std::ios::out | std::ios::binary);
  io.seekg(500);
  char c = 0;
  io.get(c);
  io.seekp(500);
  io.put(static_cast<char>(c ^ 0x20));
}

TEST(StoreRpc, CorruptBlobsOnDiskAnswerDataLossAndAreQuarantined) {
  ServerProcess server(/*local_workers=*/0);
  const Damage cases[] = {
      {"byte flipped before the first read", false, FlipAByte},
      {"byte flipped after a good read", true, FlipAByte},
      {"truncated after a good read", true, [](const fs::path& f) { fs::resize_file(f, fs::file_size(f) - 100); }},
  };
  uint32_t seed = 1;
  for (const Damage& c : cases) {
    const std::string bytes = RandomBytes(64 << 10, seed++);
    const v1::Digest digest = DigestOf(bytes);
    ASSERT_TRUE(UploadBytes(server.assets(), bytes, digest).ok()) << c.name;
    std::string got;
    if (c.read_first) {
      ASSERT_TRUE(ReadBlob(server.assets(), digest, &got).ok()) << c.name;
      ASSERT_EQ(got, bytes) << c.name;
    }
    const fs::path file = BlobFile(server, digest.hash());
    ASSERT_TRUE(fs::exists(file)) << c.name << ": " << file;
    // The file is read-only once published; the damage is done as root or
    // by making it writable first, as a disk fault would not ask.
    fs::permissions(file, fs::perms::owner_write, fs::perm_options::add);
    c.apply(file);
    const grpc::Status s = ReadBlob(server.assets(), digest, &got);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::DATA_LOSS) << c.name << ": " << s.error_message();
    EXPECT_NE(s.error_message().find(digest.hash()), std::string::npos) << c.name << ": " << s.error_message();
    EXPECT_TRUE(got.empty() || got.size() < bytes.size()) << c.name << ": corrupt bytes were served whole";
    EXPECT_TRUE(IsMissing(server, digest)) << c.name << ": a quarantined blob must be reported missing";
    // Uploading the right bytes again repairs it.
    ASSERT_TRUE(UploadBytes(server.assets(), bytes, digest).ok()) << c.name;
    ASSERT_TRUE(ReadBlob(server.assets(), digest, &got).ok()) << c.name;
    EXPECT_EQ(got, bytes) << c.name;
  }
}

// A server killed mid-upload: the half-written blob never becomes visible,
// its temporary file is removed at the next start, and the upload can be
// made again.
TEST(StoreRpc, AnUploadCutByAServerKillLeavesNothingVisible) {
  ServerProcess server(/*local_workers=*/0);
  const std::string bytes = RandomBytes(8 << 20, 77);
  const v1::Digest digest = DigestOf(bytes);
  const fs::path tmp = server.data_dir() / "tmp";
  {
    auto ctx = ContextWithin();
    v1::UploadBlobResponse response;
    auto writer = server.assets().UploadBlob(ctx.get(), &response);
    v1::UploadBlobRequest chunk;
    *chunk.mutable_digest() = digest;
    chunk.set_data(bytes.substr(0, 1 << 20));
    ASSERT_TRUE(writer->Write(chunk));
    // The server has started writing its temporary file.
    ASSERT_TRUE(WaitForDirectory(tmp, [&] { return !fs::is_empty(tmp) && fs::file_size(*fs::directory_iterator(tmp)) > 0; }))
        << "no temporary file appeared in " << tmp;
    server.Kill();
    EXPECT_FALSE(writer->Finish().ok());
  }
  EXPECT_FALSE(fs::is_empty(tmp)) << "the kill left the temporary file (what the restart must clean up)";
  EXPECT_FALSE(fs::exists(BlobFile(server, digest.hash())));
  // A start removes only unfinished uploads older than an hour (a replica on
  // a shared --blob-dir must not delete another replica's live upload; the
  // young case is BlobStoreTest's): age the leftover as an hour-old crash.
  for (const auto& entry : fs::directory_iterator(tmp)) {
    fs::last_write_time(entry.path(), fs::file_time_type::clock::now() - std::chrono::hours(2));
  }

  server.Restart();
  EXPECT_TRUE(fs::is_empty(tmp)) << "leftovers older than an hour are removed at start";
  EXPECT_TRUE(IsMissing(server, digest)) << "a half-written blob must never be visible";
  std::string got;
  EXPECT_EQ(ReadBlob(server.assets(), digest, &got).error_code(), grpc::StatusCode::NOT_FOUND);
  ASSERT_TRUE(UploadBytes(server.assets(), bytes, digest).ok());
  ASSERT_TRUE(ReadBlob(server.assets(), digest, &got).ok());
  EXPECT_TRUE(got == bytes);
}

TEST(StoreRpc, ACachedResultWithACorruptMapIsBakedAgain) {
  ServerProcess server(/*local_workers=*/0);
  const PublishedResult published = PublishResult(server, {64 << 10, 32 << 10, 16 << 10}, 7);
  auto ctx = ContextWithin();
  v1::GetResultRequest get;
  get.set_cache_key(published.key);
  v1::Manifest manifest;
  ASSERT_TRUE(server.assets().GetResult(ctx.get(), get, &manifest).ok());
  const v1::Digest map = manifest.maps(0).digest();
  const fs::path file = BlobFile(server, map.hash());
  fs::permissions(file, fs::perms::owner_write, fs::perm_options::add);
  FlipAByte(file);
  std::string got;
  ASSERT_EQ(ReadBlob(server.assets(), map, &got).error_code(), grpc::StatusCode::DATA_LOSS);

  // The same request again (PublishResult's model and parameters): a miss,
  // queued for a worker, not an answer pointing at lost bytes.
  v1::SubmitBakeRequest submit;
  const std::string model = "glTF" + RandomBytes(64, 7);
  submit.mutable_mesh()->mutable_entry()->set_path("model.glb");
  *submit.mutable_mesh()->mutable_entry()->mutable_digest() = DigestOf(model);
  submit.mutable_parameters()->set_frames(3);
  submit.mutable_parameters()->set_resolution(64);
  auto submit_ctx = ContextWithin();
  v1::SubmitBakeResponse response;
  const grpc::Status s = server.bake().SubmitBake(submit_ctx.get(), submit, &response);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(response.cache_key(), published.key);
  EXPECT_FALSE(response.cached());
  EXPECT_EQ(response.job().state(), v1::JOB_STATE_QUEUED);
}

TEST(StoreRpc, TheCapEvictsLeastRecentlyUsedResultsButNeverPinnedOnesNorYoungUploads) {
  // Each result is about 170 KiB; the cap holds two and a half.
  const std::vector<int64_t> maps = {100 << 10, 50 << 10, 20 << 10};
  const int64_t cap = 425 << 10;
  ServerProcess server(/*local_workers=*/0, {"--store-max-bytes=" + std::to_string(cap)});
  ChildProcess& log = server.process();

  const PublishedResult a = PublishResult(server, maps, 101);
  ASSERT_TRUE(Pin(server, a.key, true).ok());
  const std::string loose = RandomBytes(10 << 10, 100);  // an upload no job refers to (yet)
  ASSERT_TRUE(UploadBytes(server.assets(), loose, DigestOf(loose)).ok());
  const PublishedResult b = PublishResult(server, maps, 102);
  const PublishedResult c = PublishResult(server, maps, 103);  // over the cap now

  ASSERT_TRUE(log.WaitForLog("event=evict_result cache_key=" + b.key)) << log.Stderr();
  EXPECT_EQ(GetResult(server, b.key).error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_TRUE(GetResult(server, a.key).ok()) << "pinned, although least recently used";
  EXPECT_TRUE(GetResult(server, c.key).ok());
  EXPECT_FALSE(IsMissing(server, DigestOf(loose))) << "uploads younger than the grace period are spared";
  EXPECT_EQ(log.CountInLog("event=evict_result"), 1) << "one eviction brought the store under its cap";

  // Unpinned, A is the least recently used and goes next; C, pinned, stays.
  ASSERT_TRUE(Pin(server, a.key, false).ok());
  ASSERT_TRUE(Pin(server, c.key, true).ok());
  const PublishedResult d = PublishResult(server, maps, 104);
  ASSERT_TRUE(log.WaitForLog("event=evict_result cache_key=" + a.key)) << log.Stderr();
  EXPECT_EQ(GetResult(server, a.key).error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_TRUE(GetResult(server, c.key).ok());
  EXPECT_TRUE(GetResult(server, d.key).ok());

  // Bad requests name the field.
  const grpc::Status malformed = Pin(server, "not-a-key", true);
  EXPECT_EQ(malformed.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << malformed.error_message();
  EXPECT_NE(malformed.error_message().find("cache_key"), std::string::npos) << malformed.error_message();
  EXPECT_EQ(Pin(server, std::string(64, 'e'), true).error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(Pin(server, b.key, true).error_code(), grpc::StatusCode::NOT_FOUND) << "an evicted result";
}

TEST(StoreRpc, AnUnusedUploadIsEvictedOnlyAfterItsGraceAndAPinnedResultNever) {
  // A result is about 170 KiB; the cap is below even one: only the pin
  // keeps that one.
  const std::vector<int64_t> maps = {100 << 10, 50 << 10, 20 << 10};
  const std::string cap = "--store-max-bytes=" + std::to_string(150 << 10);
  const std::string loose = RandomBytes(64 << 10, 300);  // an upload no job refers to

  // Without a cap: a result, pinned, and the upload.
  std::optional<ServerProcess> server;
  server.emplace(/*local_workers=*/0);
  const fs::path data = server->data_dir();
  const PublishedResult pinned = PublishResult(*server, maps, 301);
  ASSERT_TRUE(Pin(*server, pinned.key, true).ok());
  ASSERT_TRUE(UploadBytes(server->assets(), loose, DigestOf(loose)).ok());

  // With the cap and a grace longer than the test: the pass that evicts a
  // new result (after looking at unused blobs first) spares the upload.
  server.reset();
  server.emplace(/*local_workers=*/0, data, "127.0.0.1:0",
                 std::vector<std::string>{cap, "--store-eviction-grace-seconds=3600"});
  const PublishedResult victim = PublishResult(*server, maps, 302);
  ASSERT_TRUE(server->process().WaitForLog("event=evict_result cache_key=" + victim.key))
      << server->process().Stderr();
  EXPECT_FALSE(IsMissing(*server, DigestOf(loose))) << "evicted within its grace";
  EXPECT_TRUE(GetResult(*server, pinned.key).ok());

  // A one-second grace, which the upload is past: it goes; the pinned
  // result stays, although the store stays over its cap.
  server.reset();
  server.emplace(/*local_workers=*/0, data, "127.0.0.1:0",
                 std::vector<std::string>{cap, "--store-eviction-grace-seconds=1"});
  ASSERT_TRUE(server->process().WaitForLog("event=store_evicted ")) << server->process().Stderr();
  EXPECT_TRUE(IsMissing(*server, DigestOf(loose))) << server->process().Stderr();
  EXPECT_TRUE(GetResult(*server, pinned.key).ok());
  for (const auto& [name, bytes] : pinned.files) {
    EXPECT_FALSE(IsMissing(*server, DigestOf(bytes))) << "a blob of the pinned result was evicted: " << name;
  }
  EXPECT_EQ(server->process().CountInLog("event=evict_result"), 0) << server->process().Stderr();
}

TEST(StoreRpc, TheEvictionGraceFlagRefusesValuesOutOfRange) {
  const fs::path data = NewTempDir("grace_flag");
  for (const char* bad : {"-1", "86401"}) {
    const ToolRun run = RunTool({(BinaryDir() / "impostor-server").string(), "--data", data.string(),
                                 "--listen", "127.0.0.1:0", std::string("--store-eviction-grace-seconds=") + bad});
    EXPECT_EQ(run.exit_code, 2) << run.err;
    EXPECT_NE(run.err.find("--store-eviction-grace-seconds: " + std::string(bad) + " is out of range 0..86400"),
              std::string::npos)
        << run.err;
  }
}

// Submits a unique tiny model as `client` (empty: no metadata).
grpc::Status SubmitAs(ServerProcess& server, const std::string& client, uint32_t seed, std::string* job_id = nullptr) {
  const std::string model = "glTF" + RandomBytes(64, 5000 + seed);
  v1::SubmitBakeRequest submit;
  submit.mutable_mesh()->mutable_entry()->set_path("model.glb");
  *submit.mutable_mesh()->mutable_entry()->mutable_digest() = DigestOf(model);
  EXPECT_TRUE(UploadBytes(server.assets(), model, submit.mesh().entry().digest()).ok());
  submit.mutable_parameters()->set_frames(3);
  submit.mutable_parameters()->set_resolution(64);
  auto ctx = ContextWithin();
  if (!client.empty()) ctx->AddMetadata("impostor-client-id", client);
  v1::SubmitBakeResponse response;
  const grpc::Status s = server.bake().SubmitBake(ctx.get(), submit, &response);
  if (job_id) *job_id = response.job_id();
  return s;
}

TEST(ClientIdentity, PerClientLimitsCountTheClientIdSentOverTheWire) {
  ServerProcess server(/*local_workers=*/0, {"--max-pending-per-client=1"});
  ASSERT_TRUE(SubmitAs(server, "alice", 1).ok());
  const grpc::Status refused = SubmitAs(server, "alice", 2);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.error_message();
  EXPECT_NE(refused.error_message().find("\"alice\""), std::string::npos) << refused.error_message();
  EXPECT_NE(refused.error_message().find("1"), std::string::npos) << "names the limit: " << refused.error_message();
  EXPECT_TRUE(SubmitAs(server, "bob", 3).ok()) << "another client has its own allowance";
  // Without metadata, the address is the identity: one for this process.
  EXPECT_TRUE(SubmitAs(server, "", 4).ok());
  EXPECT_EQ(SubmitAs(server, "", 5).error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
}

TEST(ClientIdentity, EqualPriorityClientsAlternateWhateverTheirQueueLengths) {
  ServerProcess server(/*local_workers=*/0);
  std::map<std::string, std::string> owner;  // job id -> client
  // Alice queues four before Bob queues two.
  for (uint32_t i = 0; i < 4; ++i) {
    std::string id;
    ASSERT_TRUE(SubmitAs(server, "alice", 10 + i, &id).ok());
    owner[id] = "alice";
  }
  for (uint32_t i = 0; i < 2; ++i) {
    std::string id;
    ASSERT_TRUE(SubmitAs(server, "bob", 20 + i, &id).ok());
    owner[id] = "bob";
  }
  std::string order;
  for (int i = 0; i < 6; ++i) {
    auto ctx = ContextWithin();
    v1::LeaseJobRequest lease;
    lease.set_worker_id("w" + std::to_string(i));
    v1::LeaseJobResponse response;
    ASSERT_TRUE(server.workers().LeaseJob(ctx.get(), lease, &response).ok());
    ASSERT_TRUE(response.has_job()) << "lease " << i;
    order += owner[response.job().job_id()] == "alice" ? 'A' : 'B';
  }
  // Fewest running first, then least recently served: the two alternate
  // while both have work, then Alice's rest.
  EXPECT_TRUE(order == "ABABAA" || order == "BABAAA") << order;
}

}  // namespace
}  // namespace impostor::testing
