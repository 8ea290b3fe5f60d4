// The SDK's uploads of a model's small files many to a BatchUpdateBlobs call
// (issue 45), against the in-process fake (fake_server.h): one call for a
// model's small files while the large ones stream, several calls when they
// exceed a call's bytes, an older server (UNIMPLEMENTED) streaming every
// file, a blob refused in its batch sent once more through UploadBlob, a
// blob refused twice failing only the models that use it, and the stats.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "client/transfer/blob_batch_upload.h"
#include "client/transfer/mesh_files.h"
#include "client/transfer/mesh_upload.h"
#include "client/transport/transport.h"
#include "common/net/batch_read.h"
#include "tests/client/fake_server.h"

namespace impostor::sdk {
namespace {

const fs::path kWaterBottle = kAssets / "props_pbr/WaterBottle/glTF/WaterBottle.gltf";

class BlobBatchUploadTest : public FakeServerTest {
 protected:
  void SetUp() override {
    FakeServerTest::SetUp();
    fs::create_directories(dir_);
    std::lock_guard lock(fake_.mu);
    fake_.batch_updates = true;
  }

  std::unique_ptr<Transport> ConnectTransport() {
    ClientOptions options;
    options.server = "127.0.0.1:" + std::to_string(port_);
    options.connect_timeout_seconds = 5;
    options.max_attempts = 2;
    options.max_outage_seconds = 0;
    absl::StatusOr<std::unique_ptr<Transport>> transport = Transport::Connect(options);
    EXPECT_TRUE(transport.ok()) << transport.status();
    return transport.ok() ? std::move(*transport) : nullptr;
  }

  // A file of `size` bytes in dir_, its bytes depending on `seed`.
  fs::path Write(const std::string& name, size_t size, int seed) {
    std::string bytes(size, '\0');
    for (size_t i = 0; i < size; ++i) bytes[i] = static_cast<char>((i * 31 + static_cast<size_t>(seed) * 7919) >> 3);
    const fs::path path = dir_ / name;
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
  }

  // A model of the files `names` in dir_ (entry first).
  static MeshFiles Model(const std::vector<fs::path>& paths) {
    MeshFiles model;
    model.entry = paths.front();
    model.entry_name = paths.front().filename().string();
    for (size_t i = 1; i < paths.size(); ++i) model.files.push_back({paths[i].filename().string(), paths[i]});
    return model;
  }

  // The sizes of a model's files at most kUploadBatchMaxBytes, and of the rest.
  static void Split(const MeshFiles& model, int* small, int* large) {
    *small = *large = 0;
    auto count = [&](const fs::path& p) {
      ++(static_cast<int64_t>(fs::file_size(p)) <= kUploadBatchMaxBytes ? *small : *large);
    };
    count(model.entry);
    for (const MeshFile& f : model.files) count(f.local_path);
  }
};

TEST_F(BlobBatchUploadTest, SubmitSendsTheSmallFilesInOneCallAndStreamsTheLargeOnes) {
  absl::StatusOr<MeshFiles> files = CollectMeshFiles(kWaterBottle);
  ASSERT_TRUE(files.ok()) << files.status();
  int small = 0, large = 0;
  Split(*files, &small, &large);
  ASSERT_GE(small, 2) << "the .gltf and the emissive map (59 KB)";
  ASSERT_GE(large, 1);
  int64_t total = static_cast<int64_t>(fs::file_size(files->entry));
  for (const MeshFile& f : files->files) total += static_cast<int64_t>(fs::file_size(f.local_path));

  absl::StatusOr<SubmitResult> r = client_->SubmitBake(kWaterBottle, {});
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->upload.files, small + large);
  EXPECT_EQ(r->upload.uploaded, small + large);
  EXPECT_EQ(r->upload.bytes_uploaded, total);
  std::lock_guard lock(fake_.mu);
  ASSERT_EQ(fake_.batch_updates_seen.size(), 1u) << "one round trip for every small file";
  EXPECT_EQ(fake_.batch_updates_seen[0].size(), static_cast<size_t>(small));
  EXPECT_EQ(fake_.uploaded.size(), static_cast<size_t>(large)) << "only the large files stream";
  EXPECT_EQ(fake_.upload_calls, large);
}

TEST_F(BlobBatchUploadTest, SmallFilesOverOneCallsBytesGoInSeveralOfOneMessageEach) {
  // 12 files of 20 KiB: 3 to a call of at most kUploadBatchMaxBytes (one
  // upload message, what a slow uplink must carry within the stall time;
  // the first call also takes the .gltf); two files of the same bytes are
  // one blob, sent once; a file one byte over the limit streams.
  std::vector<fs::path> paths = {Write("model.gltf", 900, 0)};
  for (int i = 0; i < 12; ++i) paths.push_back(Write("tex_" + std::to_string(i) + ".png", 20 << 10, i + 1));
  paths.push_back(Write("copy_of_tex_0.png", 20 << 10, 1));
  paths.push_back(Write("large.png", static_cast<size_t>(kUploadBatchMaxBytes) + 1, 99));
  const MeshFiles model = Model(paths);
  auto transport = ConnectTransport();
  ASSERT_NE(transport, nullptr);
  absl::StatusOr<UploadedMesh> uploaded = UploadMesh(*transport, model);
  ASSERT_TRUE(uploaded.ok()) << uploaded.status();
  EXPECT_EQ(uploaded->stats.files, 15);
  EXPECT_EQ(uploaded->stats.uploaded, 14);
  EXPECT_EQ(uploaded->stats.bytes_uploaded, 900 + 12 * (20 << 10) + kUploadBatchMaxBytes + 1);
  std::lock_guard lock(fake_.mu);
  EXPECT_EQ(fake_.batch_updates_seen.size(), 4u);
  for (int64_t bytes : fake_.batch_update_bytes) EXPECT_LE(bytes, kUploadBatchMaxBytes);
  EXPECT_EQ(fake_.batch_uploaded.size(), 13u);
  EXPECT_EQ(std::set<std::string>(fake_.batch_uploaded.begin(), fake_.batch_uploaded.end()).size(), 13u);
  EXPECT_EQ(fake_.uploaded.size(), 1u) << "only the file over the limit streams";
}

TEST_F(BlobBatchUploadTest, AnOlderServerGetsEveryFileThroughUploadBlobAndIsAskedOnce) {
  {
    std::lock_guard lock(fake_.mu);
    fake_.batch_updates = false;
  }
  std::vector<fs::path> paths = {Write("model.gltf", 900, 0)};
  for (int i = 0; i < 12; ++i) paths.push_back(Write("tex_" + std::to_string(i) + ".png", 20 << 10, i + 1));
  auto transport = ConnectTransport();
  ASSERT_NE(transport, nullptr);
  absl::StatusOr<UploadedMesh> uploaded = UploadMesh(*transport, Model(paths));
  ASSERT_TRUE(uploaded.ok()) << uploaded.status();
  EXPECT_EQ(uploaded->stats.uploaded, 13);
  EXPECT_EQ(uploaded->stats.bytes_uploaded, 900 + 12 * (20 << 10));
  std::lock_guard lock(fake_.mu);
  EXPECT_EQ(fake_.batch_update_attempts, 1) << "no second batch after UNIMPLEMENTED (four were packed)";
  EXPECT_EQ(fake_.uploaded.size(), 13u);
}

TEST_F(BlobBatchUploadTest, ABlobRefusedInItsBatchIsStreamedOnceMoreAndTheSubmitWorks) {
  absl::StatusOr<MeshFiles> files = CollectMeshFiles(kWaterBottle);
  ASSERT_TRUE(files.ok()) << files.status();
  const std::string gltf = Sha256Hex(ReadAll(files->entry));
  {
    std::lock_guard lock(fake_.mu);
    fake_.refuse_in_batch.insert(gltf);
  }
  absl::StatusOr<SubmitResult> r = client_->SubmitBake(kWaterBottle, {});
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->upload.uploaded, r->upload.files);
  EXPECT_EQ(r->upload.bytes_uploaded, r->upload.bytes_total);
  std::lock_guard lock(fake_.mu);
  EXPECT_EQ(std::count(fake_.uploaded.begin(), fake_.uploaded.end(), gltf), 1) << "streamed once";
  EXPECT_EQ(std::count(fake_.batch_uploaded.begin(), fake_.batch_uploaded.end(), gltf), 0);
  EXPECT_EQ(fake_.submits.size(), 1u);
}

// A full store refuses the small blob in its batch and on its stream: the
// model that uses it fails naming the file and both refusals; the other
// model is submitted, and its stats count what it uploaded.
TEST_F(BlobBatchUploadTest, ABlobRefusedTwiceFailsOnlyTheModelsThatUseIt) {
  const fs::path box = kAssets / "props_pbr/Box/glTF-Binary/Box.glb";
  // Both small enough for a batch (Duck.glb, 120 KB, streams).
  const fs::path duck = kAssets / "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb";
  ASSERT_LT(fs::file_size(box), fs::file_size(duck));
  ASSERT_LE(static_cast<int64_t>(fs::file_size(box) + fs::file_size(duck)), kUploadBatchMaxBytes);
  {
    std::lock_guard lock(fake_.mu);
    fake_.refuse_uploads_over = static_cast<int64_t>(fs::file_size(box));
  }
  absl::StatusOr<std::vector<BatchSubmission>> r =
      client_->SubmitBakeBatch({{duck, {}}, {box, {}}, {duck, {}}}, nullptr);
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_EQ(r->size(), 3u);
  for (size_t i : {0u, 2u}) {
    const absl::Status& s = (*r)[i].status;
    EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted) << s;
    EXPECT_NE(s.message().find("BoxTextured.glb"), std::string::npos) << s;
    EXPECT_NE(s.message().find("refused in its batch first: RESOURCE_EXHAUSTED"), std::string::npos) << s;
  }
  ASSERT_TRUE((*r)[1].status.ok()) << (*r)[1].status;
  EXPECT_EQ((*r)[1].result.upload.uploaded, 1);
  EXPECT_EQ((*r)[1].result.upload.bytes_uploaded, static_cast<int64_t>(fs::file_size(box)));
  std::lock_guard lock(fake_.mu);
  EXPECT_EQ(fake_.batch_updates_seen.size(), 1u) << "both blobs in one call";
  EXPECT_EQ(fake_.upload_calls, 1) << "the refused one streamed once more, the other not at all";
  ASSERT_EQ(fake_.submits.size(), 1u) << "only the box";
}

// Each blob's outcome, table-driven over how the whole call is answered: a
// refusal of the request (a quota) sends its blobs through the stream; a
// refusal of the caller or a dead link ends the upload.
TEST_F(BlobBatchUploadTest, AWholeCallsRefusalStreamsItsBlobsAndACallersRefusalEndsTheUpload) {
  struct Case {
    std::string name;
    grpc::StatusCode call;
    absl::StatusCode want;  // of UploadBlobFiles as a whole
    int streams;
  };
  const std::vector<Case> cases = {
      {"quota", grpc::StatusCode::RESOURCE_EXHAUSTED, absl::StatusCode::kOk, 2},
      {"unauthenticated", grpc::StatusCode::UNAUTHENTICATED, absl::StatusCode::kUnauthenticated, 0},
      {"permission denied", grpc::StatusCode::PERMISSION_DENIED, absl::StatusCode::kPermissionDenied, 0},
      {"server down", grpc::StatusCode::UNAVAILABLE, absl::StatusCode::kUnavailable, 0},
  };
  auto transport = ConnectTransport();
  ASSERT_NE(transport, nullptr);
  int n = 0;
  for (const Case& c : cases) {
    const fs::path a = Write("a" + std::to_string(n), 1000, 100 + n), b = Write("b" + std::to_string(n), 2000, 200 + n);
    ++n;
    {
      std::lock_guard lock(fake_.mu);
      fake_.batch_update_code = c.call;
      fake_.upload_calls = 0;
    }
    absl::StatusOr<std::vector<absl::Status>> each = UploadBlobFiles(
        *transport, {{a, DigestOf(ReadAll(a))}, {b, DigestOf(ReadAll(b))}});
    EXPECT_EQ(each.status().code(), c.want) << c.name << ": " << each.status();
    if (each.ok()) {
      ASSERT_EQ(each->size(), 2u) << c.name;
      for (const absl::Status& s : *each) EXPECT_TRUE(s.ok()) << c.name << ": " << s;
    } else {
      EXPECT_NE(each.status().message().find("BatchUpdateBlobs"), std::string::npos) << c.name << ": " << each.status();
    }
    std::lock_guard lock(fake_.mu);
    EXPECT_EQ(fake_.upload_calls, c.streams) << c.name;
  }
}

// Bad inputs keep failing clearly: bytes that no longer match their digest
// (a file changed since it was hashed) are refused in the batch and on the
// stream, that blob alone; a file that cannot be read ends the upload
// naming it.
TEST_F(BlobBatchUploadTest, BadInputsFailNamingWhatIsWrong) {
  auto transport = ConnectTransport();
  ASSERT_NE(transport, nullptr);
  const fs::path good = Write("good.bin", 3000, 1), changed = Write("changed.bin", 3000, 2);
  const v1::Digest good_digest = DigestOf(ReadAll(good));
  v1::Digest stale = DigestOf(ReadAll(changed));
  Write("changed.bin", 3000, 3);
  absl::StatusOr<std::vector<absl::Status>> each =
      UploadBlobFiles(*transport, {{changed, stale}, {good, good_digest}});
  ASSERT_TRUE(each.ok()) << each.status();
  ASSERT_EQ(each->size(), 2u);
  EXPECT_EQ((*each)[0].code(), absl::StatusCode::kInvalidArgument) << (*each)[0];
  EXPECT_NE((*each)[0].message().find("refused in its batch first: INVALID_ARGUMENT"), std::string::npos)
      << (*each)[0];
  EXPECT_TRUE((*each)[1].ok()) << (*each)[1];

  const fs::path gone = dir_ / "gone.bin";
  absl::StatusOr<std::vector<absl::Status>> missing =
      UploadBlobFiles(*transport, {{gone, good_digest}});
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kInternal) << missing.status();
  EXPECT_NE(missing.status().message().find(gone.string()), std::string::npos) << missing.status();

  // Through UploadMesh, refused twice: the model's error names the file.
  const fs::path gltf = Write("m.gltf", 500, 4);
  {
    std::lock_guard lock(fake_.mu);
    fake_.refuse_uploads_over = 100;
  }
  absl::StatusOr<UploadedMesh> uploaded = UploadMesh(*transport, Model({gltf}));
  EXPECT_EQ(uploaded.status().code(), absl::StatusCode::kResourceExhausted) << uploaded.status();
  EXPECT_NE(uploaded.status().message().find("uploading " + gltf.string()), std::string::npos) << uploaded.status();
  EXPECT_NE(uploaded.status().message().find("refused in its batch first: RESOURCE_EXHAUSTED"), std::string::npos)
      << uploaded.status();
}

}  // namespace
}  // namespace impostor::sdk
