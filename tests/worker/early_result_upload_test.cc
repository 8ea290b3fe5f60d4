// The maps' upload beside the bake (worker/early_result_upload.h) against
// the real AssetService over a BlobStore, behind a decorator that can hold
// a stream open or refuse it: offered files are stored with their digests;
// Finish cancels a stream under way (and the upload after the bake resumes
// it); a refused upload is tried once and left, never failing anything;
// nothing goes up for a cancelled job or after Finish.
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>

#include <grpc/grpc.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "common/util/sha256.h"
#include "tests/worker/in_process_assets.h"
#include "worker/early_result_upload.h"
#include "worker/result_upload.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

class GrpcForTheWholeBinary : public ::testing::Environment {
 public:
  void SetUp() override { grpc_init(); }
};
::testing::Environment* const kGrpc = ::testing::AddGlobalTestEnvironment(new GrpcForTheWholeBinary);

constexpr auto kWait = std::chrono::seconds(60);

// The real service. `hold` keeps every UploadBlob stream open after its
// first message until the client cancels it; `refuse` answers every upload
// RESOURCE_EXHAUSTED, as a full store does. Calls and their ends are
// counted under mu, with `changed` notified.
class ControlledAssets final : public v1::AssetService::Service {
 public:
  explicit ControlledAssets(v1::AssetService::Service* inner) : inner_(inner) {}

  grpc::Status UploadBlob(grpc::ServerContext* context, grpc::ServerReader<v1::UploadBlobRequest>* reader,
                          v1::UploadBlobResponse* response) override {
    Count(&uploads_started);
    if (refuse) return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED, "the store is full");
    grpc::Status s;
    if (hold) {
      v1::UploadBlobRequest first;
      reader->Read(&first);
      Count(&held);
      // The sync API has no cancellation callback: the flag is looked at
      // until the client's cancel arrives (bounded, so a broken Finish
      // fails the test instead of hanging it).
      const auto end = Clock::now() + kWait;
      while (!context->IsCancelled() && Clock::now() < end) {
        std::unique_lock lock(mu);
        changed.wait_for(lock, std::chrono::milliseconds(5));
      }
      if (context->IsCancelled()) Count(&cancelled_seen);
      s = grpc::Status(grpc::StatusCode::CANCELLED, "held until cancelled");
    } else {
      s = inner_->UploadBlob(context, reader, response);
    }
    if (s.ok()) Count(&uploads_stored);
    return s;
  }
  grpc::Status QueryUpload(grpc::ServerContext* context, const v1::QueryUploadRequest* request,
                           v1::QueryUploadResponse* response) override {
    return inner_->QueryUpload(context, request, response);
  }
  grpc::Status BatchUpdateBlobs(grpc::ServerContext* context, const v1::BatchUpdateBlobsRequest* request,
                                v1::BatchUpdateBlobsResponse* response) override {
    Count(&batches_started);
    if (refuse) return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED, "the store is full");
    grpc::Status s = inner_->BatchUpdateBlobs(context, request, response);
    if (s.ok()) Count(&batches_stored);
    return s;
  }

  // Waits until `*counter` reaches `n`; false after kWait.
  bool WaitFor(const int* counter, int n) {
    std::unique_lock lock(mu);
    return changed.wait_for(lock, kWait, [&] { return *counter >= n; });
  }
  int Get(const int* counter) {
    std::lock_guard lock(mu);
    return *counter;
  }

  std::mutex mu;
  std::condition_variable changed;
  int uploads_started = 0, uploads_stored = 0, held = 0, cancelled_seen = 0;  // guarded by mu
  int batches_started = 0, batches_stored = 0;                                // guarded by mu
  std::atomic<bool> hold{false};
  std::atomic<bool> refuse{false};

 private:
  void Count(int* counter) {
    {
      std::lock_guard lock(mu);
      ++*counter;
    }
    changed.notify_all();
  }

  v1::AssetService::Service* const inner_;
};

class EarlyResultUploadTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("impostor_early_upload_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "result");
    ASSERT_NO_FATAL_FAILURE(server_.Start(dir_, [this](v1::AssetService::Service* real) {
      auto controlled = std::make_unique<ControlledAssets>(real);
      assets_ = controlled.get();
      return controlled;
    }));
    call_ = [this](const std::function<absl::Status(v1::AssetService::Stub&)>& rpc) { return rpc(server_.stub()); };
  }

  void TearDown() override { fs::remove_all(dir_); }

  // A map file `name` of `size` patterned bytes and its digest.
  std::pair<fs::path, BlobDigest> Write(const std::string& name, size_t size, uint32_t seed) {
    std::string bytes(size, '\0');
    for (size_t i = 0; i < size; ++i) bytes[i] = static_cast<char>((i * 197 + seed * 31) ^ (i >> 9));
    const fs::path path = dir_ / "result" / name;
    std::ofstream(path, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(size));
    auto digest = DigestFile(path);
    EXPECT_TRUE(digest.ok()) << digest.status();
    return {path, *digest};
  }

  // The store's bytes of `digest`, or "" when it does not hold them.
  std::string Stored(const BlobDigest& digest) {
    auto data = server_.store().ReadAll(digest);
    return data.ok() ? *data : std::string();
  }

  fs::path dir_;
  testing::InProcessAssets server_;
  ControlledAssets* assets_ = nullptr;  // owned by server_
  std::function<absl::Status(const std::function<absl::Status(v1::AssetService::Stub&)>&)> call_;
  std::atomic<bool> job_cancelled_{false};
};

TEST_F(EarlyResultUploadTest, OfferedMapsAreStoredWhileTheBakeGoesOn) {
  const auto [big_path, big] = Write("albedo_alpha.png", 3 << 20, 1);  // streamed
  const auto [small_path, small] = Write("orm.png", 20'000, 2);       // one small batch
  EarlyResultUpload early(call_, job_cancelled_);
  early.Offer(big_path, big);
  early.Offer(small_path, small);
  // Both are in the store before the bake ends (before Finish).
  ASSERT_TRUE(assets_->WaitFor(&assets_->uploads_stored, 1));
  ASSERT_TRUE(assets_->WaitFor(&assets_->batches_stored, 1));
  EXPECT_EQ(Stored(big).size(), size_t{3} << 20);
  EXPECT_EQ(Stored(small).size(), 20'000u);
  // A third map, held open by the server: the files go one at a time, so
  // once it is under way the client has had both answers, and Finish
  // counts exactly the two stored.
  const auto [held_path, held] = Write("normal_depth.png", 2 << 20, 7);
  assets_->hold = true;
  early.Offer(held_path, held);
  ASSERT_TRUE(assets_->WaitFor(&assets_->held, 1));
  EXPECT_EQ(early.Finish(), 2);
  EXPECT_EQ(early.Finish(), 2) << "Finish again says the same";
  EXPECT_EQ(assets_->Get(&assets_->uploads_started), 2);
  EXPECT_EQ(assets_->Get(&assets_->batches_started), 1);
}

TEST_F(EarlyResultUploadTest, FinishCancelsTheStreamUnderWayAndTheUploadAfterTheBakeSendsIt) {
  const auto [path, digest] = Write("normal_depth.png", 2 << 20, 3);
  assets_->hold = true;
  EarlyResultUpload early(call_, job_cancelled_);
  early.Offer(path, digest);
  ASSERT_TRUE(assets_->WaitFor(&assets_->held, 1)) << "the stream never started";
  // The bake is over while the map is still going up: Finish does not wait
  // for the stream (a stalled link would hold the job for minutes).
  EXPECT_EQ(early.Finish(), 0);
  ASSERT_TRUE(assets_->WaitFor(&assets_->cancelled_seen, 1)) << "the server never saw the stream cancelled";
  EXPECT_EQ(Stored(digest), "");
  // The upload after the bake stores it.
  assets_->hold = false;
  v1::Digest d;
  d.set_hash(digest.hash);
  d.set_size_bytes(digest.size_bytes);
  ASSERT_TRUE(UploadResultFile(server_.stub(), path, d).ok());
  EXPECT_EQ(Stored(digest).size(), size_t{2} << 20);
}

TEST_F(EarlyResultUploadTest, ARefusedUploadIsTriedOnceAndLeftForLater) {
  const auto [big_path, big] = Write("albedo_alpha.png", 2 << 20, 4);
  const auto [small_path, small] = Write("orm.png", 10'000, 5);
  assets_->refuse = true;
  EarlyResultUpload early(call_, job_cancelled_);
  early.Offer(big_path, big);
  early.Offer(small_path, small);
  ASSERT_TRUE(assets_->WaitFor(&assets_->uploads_started, 1));
  ASSERT_TRUE(assets_->WaitFor(&assets_->batches_started, 1));
  EXPECT_EQ(early.Finish(), 0);
  // One try each: no retry, no wait for space (the upload after the bake
  // does that).
  EXPECT_EQ(assets_->Get(&assets_->uploads_started), 1);
  EXPECT_EQ(assets_->Get(&assets_->batches_started), 1);
  EXPECT_EQ(Stored(big), "");
}

TEST_F(EarlyResultUploadTest, NothingGoesUpForACancelledJobOrAfterFinish) {
  const auto [path, digest] = Write("albedo_alpha.png", 1 << 20, 6);
  {
    job_cancelled_ = true;
    EarlyResultUpload early(call_, job_cancelled_);
    early.Offer(path, digest);
    EXPECT_EQ(early.Finish(), 0);
  }
  {
    job_cancelled_ = false;
    EarlyResultUpload early(call_, job_cancelled_);
    EXPECT_EQ(early.Finish(), 0);
    early.Offer(path, digest);  // ignored
    EXPECT_EQ(early.Finish(), 0);
  }
  EXPECT_EQ(assets_->Get(&assets_->uploads_started) + assets_->Get(&assets_->batches_started), 0);
  EXPECT_EQ(Stored(digest), "");
}

}  // namespace
}  // namespace impostor
