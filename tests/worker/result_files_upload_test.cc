// A result's upload as the worker plans it (worker/result_files_upload.h)
// against the real AssetService over a BlobStore, behind a decorator that
// counts the calls and can play an older server or damage one blob of a
// batch: the small files go in one BatchUpdateBlobs call and the large ones
// are streamed; an older server's UNIMPLEMENTED sends every file through
// UploadBlob; a blob refused in its batch is uploaded again once, and a
// file that is refused twice fails the upload naming it.
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>
#include <vector>

#include <grpc/grpc.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "common/net/batch_read.h"
#include "common/util/sha256.h"
#include "tests/worker/in_process_assets.h"
#include "worker/result_files_upload.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

class GrpcForTheWholeBinary : public ::testing::Environment {
 public:
  void SetUp() override { grpc_init(); }
};
::testing::Environment* const kGrpc = ::testing::AddGlobalTestEnvironment(new GrpcForTheWholeBinary);

// The real service, its upload calls counted; `old_server` answers
// BatchUpdateBlobs UNIMPLEMENTED as a server that predates it does;
// `damage` flips a byte of that blob index of every batch before the
// store sees it, as a link that corrupts would.
class CountingAssets final : public v1::AssetService::Service {
 public:
  explicit CountingAssets(v1::AssetService::Service* inner) : inner_(inner) {}

  grpc::Status UploadBlob(grpc::ServerContext* context, grpc::ServerReader<v1::UploadBlobRequest>* reader,
                          v1::UploadBlobResponse* response) override {
    ++uploads;
    return inner_->UploadBlob(context, reader, response);
  }
  grpc::Status QueryUpload(grpc::ServerContext* context, const v1::QueryUploadRequest* request,
                           v1::QueryUploadResponse* response) override {
    return inner_->QueryUpload(context, request, response);
  }
  grpc::Status BatchUpdateBlobs(grpc::ServerContext* context, const v1::BatchUpdateBlobsRequest* request,
                                v1::BatchUpdateBlobsResponse* response) override {
    {
      std::lock_guard lock(mu);
      batch_sizes.push_back(request->requests_size());
    }
    if (old_server) return grpc::Status(grpc::StatusCode::UNIMPLEMENTED, "");
    if (damage < 0 || damage >= request->requests_size()) return inner_->BatchUpdateBlobs(context, request, response);
    v1::BatchUpdateBlobsRequest damaged = *request;
    std::string* data = damaged.mutable_requests(damage)->mutable_data();
    (*data)[0] = static_cast<char>((*data)[0] ^ 0x01);
    return inner_->BatchUpdateBlobs(context, &damaged, response);
  }

  std::atomic<int> uploads{0};
  std::mutex mu;
  std::vector<int> batch_sizes;  // blobs of each BatchUpdateBlobs call, guarded by mu
  bool old_server = false;       // set before the calls
  int damage = -1;               // set before the calls

 private:
  v1::AssetService::Service* const inner_;
};

class ResultFilesUploadTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("impostor_result_files_upload_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "result");
    ASSERT_NO_FATAL_FAILURE(assets_.Start(dir_, [this](v1::AssetService::Service* real) {
      auto counting = std::make_unique<CountingAssets>(real);
      counting_ = counting.get();
      return counting;
    }));
    link_.call = [this](const std::function<absl::Status(v1::AssetService::Stub&)>& rpc) {
      return rpc(assets_.stub());
    };
    link_.upload_patiently = [this](const ResultFile& file) {
      ++patient_uploads_;
      return UploadResultFile(assets_.stub(), file.path, file.digest);
    };
  }

  void TearDown() override { fs::remove_all(dir_); }

  // A result file `name` of `size` patterned bytes.
  ResultFile Write(const std::string& name, size_t size, uint32_t seed) {
    std::string bytes(size, '\0');
    for (size_t i = 0; i < size; ++i) bytes[i] = static_cast<char>((i * 197 + seed * 31) ^ (i >> 9));
    const fs::path path = dir_ / "result" / name;
    std::ofstream(path, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(size));
    v1::Digest digest;
    digest.set_hash(Sha256Hex(bytes));
    digest.set_size_bytes(static_cast<int64_t>(size));
    return {path, digest};
  }
  // A result shaped as a bake's: 36 small view images, a contact sheet and
  // a manifest, and two large atlases.
  std::vector<ResultFile> WriteResult() {
    std::vector<ResultFile> files;
    files.push_back(Write("albedo_alpha.png", 3 << 20, 1));
    files.push_back(Write("normal_depth.png", (2 << 20) + 7, 2));
    for (uint32_t v = 0; v < 36; ++v) files.push_back(Write("view_" + std::to_string(v) + ".png", 20'000 + v, 10 + v));
    files.push_back(Write("contact_sheet.png", 300'000, 50));
    files.push_back(Write("manifest.json", 4'000, 51));
    return files;
  }
  bool Stored(const ResultFile& f) { return assets_.store().Contains({f.digest.hash(), f.digest.size_bytes()}); }
  std::vector<int> BatchSizes() {
    std::lock_guard lock(counting_->mu);
    return counting_->batch_sizes;
  }

  fs::path dir_;
  testing::InProcessAssets assets_;
  CountingAssets* counting_ = nullptr;  // owned by assets_
  ResultUploadLink link_;
  std::atomic<int> patient_uploads_{0};
};

TEST_F(ResultFilesUploadTest, TheSmallFilesGoInOneBatchAndTheLargeOnesAreStreamed) {
  const std::vector<ResultFile> files = WriteResult();
  const absl::Status s = UploadResultFiles(files, link_, 4);
  ASSERT_TRUE(s.ok()) << s;
  for (const ResultFile& f : files) EXPECT_TRUE(Stored(f)) << f.path;
  EXPECT_EQ(BatchSizes(), std::vector<int>{38});
  EXPECT_EQ(counting_->uploads, 2) << "the two atlases only";
  EXPECT_EQ(patient_uploads_, 0);
}

TEST_F(ResultFilesUploadTest, SmallFilesOverOneBatchsBytesGoInSeveral) {
  std::vector<ResultFile> files;
  // Six files of 1 MiB: four fill a batch's 4 MiB exactly.
  for (uint32_t i = 0; i < 6; ++i) {
    files.push_back(Write("tile_" + std::to_string(i) + ".png", static_cast<size_t>(kBatchUpdateBlobMaxBytes), i));
  }
  const absl::Status s = UploadResultFiles(files, link_, 4);
  ASSERT_TRUE(s.ok()) << s;
  for (const ResultFile& f : files) EXPECT_TRUE(Stored(f)) << f.path;
  std::vector<int> sizes = BatchSizes();
  std::sort(sizes.begin(), sizes.end());
  EXPECT_EQ(sizes, (std::vector<int>{2, 4}));
  EXPECT_EQ(counting_->uploads, 0);
}

TEST_F(ResultFilesUploadTest, AnOlderServerGetsEveryFileThroughUploadBlob) {
  counting_->old_server = true;
  const std::vector<ResultFile> files = WriteResult();
  const absl::Status s = UploadResultFiles(files, link_, 4);
  ASSERT_TRUE(s.ok()) << s;
  for (const ResultFile& f : files) EXPECT_TRUE(Stored(f)) << f.path;
  EXPECT_EQ(BatchSizes(), std::vector<int>{38}) << "asked once";
  EXPECT_EQ(counting_->uploads, static_cast<int>(files.size()));
  EXPECT_EQ(patient_uploads_, 0) << "an older server is no refusal: streamed in the parallel pass";
}

TEST_F(ResultFilesUploadTest, ABlobRefusedInItsBatchIsUploadedAgainOnce) {
  counting_->damage = 5;
  const std::vector<ResultFile> files = WriteResult();
  const absl::Status s = UploadResultFiles(files, link_, 4);
  ASSERT_TRUE(s.ok()) << s;
  for (const ResultFile& f : files) EXPECT_TRUE(Stored(f)) << f.path;
  EXPECT_EQ(BatchSizes(), std::vector<int>{38});
  EXPECT_EQ(patient_uploads_, 1) << "the damaged blob, through UploadBlob";
  EXPECT_EQ(counting_->uploads, 3);
}

// A file whose bytes are not its digest's (changed under the worker) is
// refused in its batch and by UploadBlob: the upload fails naming the file.
TEST_F(ResultFilesUploadTest, AFileRefusedTwiceFailsTheUploadNamingIt) {
  std::vector<ResultFile> files = WriteResult();
  ResultFile& view = files[7];
  std::ofstream(view.path, std::ios::binary | std::ios::in | std::ios::out).put('X');
  const absl::Status s = UploadResultFiles(files, link_, 4);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << s;
  for (const char* part : {"result file view_5.png: UploadBlob", "refused in its batch first: INVALID_ARGUMENT"}) {
    EXPECT_NE(s.message().find(part), std::string::npos) << part << ": " << s;
  }
  EXPECT_NE(s.message().find(view.digest.hash()), std::string::npos) << s;
  EXPECT_FALSE(Stored(view));
  EXPECT_EQ(patient_uploads_, 1);
}

}  // namespace
}  // namespace impostor
