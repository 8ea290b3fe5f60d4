// The SDK against an in-process fake of the impostor.v1 services
// (fake_server.h): Submit uploads only what the server lacks and keeps the
// server's refusals; Fetch writes verified files, resumes broken downloads
// and leaves nothing behind on a corrupt one.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/client/fake_server.h"

namespace impostor::sdk {
namespace {

TEST_F(FakeServerTest, SubmitUploadsOnlyMissingFiles) {
  const fs::path model = kAssets / "props_pbr/WaterBottle/glTF/WaterBottle.gltf";
  const std::string bin = ReadAll(model.parent_path() / "WaterBottle.bin");
  {
    std::lock_guard lock(fake_.mu);
    fake_.blobs[Sha256Hex(bin)] = bin;
  }
  absl::StatusOr<SubmitResult> r = client_->SubmitBake(model, BakeSettings{.layout = "hemi-octahedral", .frames = 8, .resolution = 512});
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->job_id, "job-1");
  EXPECT_EQ(r->upload.files, 6);
  EXPECT_EQ(r->upload.uploaded, 5);
  EXPECT_EQ(r->upload.bytes_total - r->upload.bytes_uploaded, static_cast<int64_t>(bin.size()));
  std::lock_guard lock(fake_.mu);
  EXPECT_EQ(fake_.uploaded.size(), 5u);
  EXPECT_EQ(std::count(fake_.uploaded.begin(), fake_.uploaded.end(), Sha256Hex(bin)), 0);
  const v1::SubmitBakeRequest& req = fake_.last_submit;
  EXPECT_EQ(req.mesh().entry().path(), "WaterBottle.gltf");
  EXPECT_EQ(req.mesh().files_size(), 5);
  EXPECT_EQ(req.parameters().layout(), v1::LAYOUT_HEMI_OCTAHEDRAL);
  EXPECT_EQ(req.parameters().frames(), 8u);
  EXPECT_EQ(req.parameters().resolution(), 512u);
}

TEST_F(FakeServerTest, SubmitBakeBatchAsksOnceAndUploadsEachBlobOnce) {
  const fs::path bottle = kAssets / "props_pbr/WaterBottle/glTF/WaterBottle.gltf";
  const fs::path helmet = kAssets / "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb";
  BakeSettings urgent;
  urgent.priority = 50;
  urgent.min_iou = 0.9f;
  std::vector<BatchItem> items = {{bottle, {}}, {helmet, urgent}, {bottle, {}}, {kAssets / "absent.glb", {}}};
  std::vector<size_t> seen;
  absl::StatusOr<std::vector<BatchSubmission>> r =
      client_->SubmitBakeBatch(items, [&](size_t i, const BatchSubmission&) {
        seen.push_back(i);
        return true;
      });
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_EQ(r->size(), 4u);
  EXPECT_EQ(seen, (std::vector<size_t>{0, 1, 2, 3}));
  EXPECT_TRUE((*r)[0].status.ok()) << (*r)[0].status;
  EXPECT_TRUE((*r)[1].status.ok()) << (*r)[1].status;
  EXPECT_EQ((*r)[3].status.code(), absl::StatusCode::kNotFound) << "a missing model fails alone";
  EXPECT_EQ((*r)[0].result.upload.uploaded, 6) << "the first user of each blob uploads it";
  EXPECT_EQ((*r)[2].result.upload.uploaded, 0) << "the same model again uploads nothing";
  EXPECT_EQ((*r)[2].result.upload.files, 6);
  std::lock_guard lock(fake_.mu);
  EXPECT_EQ(fake_.find_missing_calls, 1) << "one FindMissingBlobs for the whole batch";
  EXPECT_EQ(fake_.uploaded.size(), std::set<std::string>(fake_.uploaded.begin(), fake_.uploaded.end()).size())
      << "no blob uploaded twice";
  EXPECT_EQ(fake_.uploaded.size(), 7u);  // WaterBottle's 6 files and the helmet
  ASSERT_EQ(fake_.submits.size(), 3u);
  EXPECT_EQ(fake_.submits[1].priority(), 50);
  EXPECT_FLOAT_EQ(fake_.submits[1].gate().min_iou(), 0.9f);
  EXPECT_FALSE(fake_.submits[1].gate().has_min_psnr_db());
  EXPECT_EQ(fake_.submits[0].priority(), 0);
  EXPECT_FALSE(fake_.submits[0].has_gate());
}

// A full disk refuses the large upload: the models that need it fail with
// that reason, and the ones that fit are still submitted.
TEST_F(FakeServerTest, SubmitBakeBatchGoesOnPastABlobTheServerHasNoRoomFor) {
  const fs::path helmet = kAssets / "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb";
  const fs::path box = kAssets / "props_pbr/Box/glTF-Binary/Box.glb";
  {
    std::lock_guard lock(fake_.mu);
    fake_.refuse_uploads_over = static_cast<int64_t>(fs::file_size(box)) + 1;
  }
  absl::StatusOr<std::vector<BatchSubmission>> r =
      client_->SubmitBakeBatch({{helmet, {}}, {box, {}}, {helmet, {}}}, nullptr);
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_EQ(r->size(), 3u);
  for (size_t i : {0u, 2u}) {
    EXPECT_EQ((*r)[i].status.code(), absl::StatusCode::kResourceExhausted) << (*r)[i].status;
    EXPECT_NE((*r)[i].status.message().find("DamagedHelmet.glb"), std::string::npos) << (*r)[i].status;
  }
  EXPECT_TRUE((*r)[1].status.ok()) << (*r)[1].status;
  std::lock_guard lock(fake_.mu);
  ASSERT_EQ(fake_.submits.size(), 1u) << "only the box";
}

TEST_F(FakeServerTest, SubmitBakeBatchStopsWhenAsked) {
  const fs::path helmet = kAssets / "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb";
  std::vector<BatchItem> items(4, BatchItem{helmet, {}});
  absl::StatusOr<std::vector<BatchSubmission>> r =
      client_->SubmitBakeBatch(items, [](size_t i, const BatchSubmission&) { return i < 1; });
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_TRUE((*r)[0].status.ok());
  EXPECT_TRUE((*r)[1].status.ok());
  for (size_t i = 2; i < 4; ++i) {
    EXPECT_EQ((*r)[i].status.code(), absl::StatusCode::kCancelled) << i;
    EXPECT_EQ((*r)[i].status.message(), "not submitted: the batch stopped");
  }
  std::lock_guard lock(fake_.mu);
  EXPECT_EQ(fake_.submits.size(), 2u);
}

TEST_F(FakeServerTest, SecondSubmitUploadsNothing) {
  const fs::path model = kAssets / "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb";
  ASSERT_TRUE(client_->SubmitBake(model, {}).ok());
  absl::StatusOr<SubmitResult> again = client_->SubmitBake(model, {});
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_EQ(again->upload.uploaded, 0);
  EXPECT_EQ(again->upload.bytes_uploaded, 0);
}

TEST_F(FakeServerTest, UnknownLayoutFailsBeforeAnyRpc) {
  absl::StatusOr<SubmitResult> r =
      client_->SubmitBake(kAssets / "props_pbr/Box/glTF-Binary/Box.glb", BakeSettings{"cube", 0, 0});
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(r.status().message().find("hemi-octahedral"), std::string::npos) << r.status();
  std::lock_guard lock(fake_.mu);
  EXPECT_TRUE(fake_.uploaded.empty());
}

TEST_F(FakeServerTest, ServerRejectionKeepsCodeAndNamesRpcAndServer) {
  absl::StatusOr<SubmitResult> r =
      client_->SubmitBake(kAssets / "props_pbr/Box/glTF-Binary/Box.glb", BakeSettings{"octahedral", 80, 0});
  ASSERT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument) << r.status();
  EXPECT_NE(r.status().message().find("SubmitBake"), std::string::npos) << r.status();
  EXPECT_NE(r.status().message().find("127.0.0.1:" + std::to_string(port_)), std::string::npos) << r.status();
  std::optional<RpcErrorInfo> info = GetRpcErrorInfo(r.status());
  ASSERT_TRUE(info.has_value());
  EXPECT_EQ(info->rpc, "SubmitBake");
  EXPECT_EQ(info->server_message, "parameters.frames: 80 is out of range 2..64");
  EXPECT_EQ(info->reason, "") << "the server gave no reason";
}

// The server lost the model's blobs between the upload and the submit (an
// eviction under store pressure): the client uploads them again and the
// submit goes through, counting the second upload; twice at most, so a
// server that keeps losing them gets an answer, not a loop.
TEST_F(FakeServerTest, SubmitUploadsAgainWhatTheServerLostSinceTheUpload) {
  const fs::path model = kAssets / "props_pbr/Box/glTF-Binary/Box.glb";
  {
    std::lock_guard lock(fake_.mu);
    fake_.submit_evicts = 1;
  }
  absl::StatusOr<SubmitResult> r = client_->SubmitBake(model, BakeSettings{"octahedral", 8, 0});
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->upload.uploaded, 2) << "the one file, uploaded twice";
  {
    std::lock_guard lock(fake_.mu);
    EXPECT_EQ(fake_.submits.size(), 2u);
    EXPECT_EQ(fake_.submits[0].request_id(), fake_.submits[1].request_id()) << "one logical submit";
    fake_.submit_evicts = 5;
  }
  r = client_->SubmitBake(model, BakeSettings{"octahedral", 8, 0});
  ASSERT_EQ(r.status().code(), absl::StatusCode::kFailedPrecondition) << r.status();
  EXPECT_EQ(GetRpcErrorInfo(r.status())->reason, "INPUT_BLOB_MISSING");
  std::lock_guard lock(fake_.mu);
  EXPECT_EQ(fake_.submits.size(), 5u) << "three tries of the second submit";
}

// Without the reason (an older server) a refused submit is the answer: the
// message alone does not say what to do.
TEST_F(FakeServerTest, AMissingBlobWithoutTheReasonIsNotUploadedAgain) {
  {
    std::lock_guard lock(fake_.mu);
    fake_.submit_evicts = 1;
    fake_.missing_blob_reason = false;
  }
  absl::StatusOr<SubmitResult> r =
      client_->SubmitBake(kAssets / "props_pbr/Box/glTF-Binary/Box.glb", BakeSettings{"octahedral", 8, 0});
  ASSERT_EQ(r.status().code(), absl::StatusCode::kFailedPrecondition) << r.status();
  std::lock_guard lock(fake_.mu);
  EXPECT_EQ(fake_.submits.size(), 1u);
}

// The batch submit does the same for each model.
TEST_F(FakeServerTest, BatchSubmitUploadsAgainWhatTheServerLost) {
  {
    std::lock_guard lock(fake_.mu);
    fake_.submit_evicts = 1;
  }
  std::vector<BatchItem> items = {
      {kAssets / "props_pbr/Box/glTF-Binary/Box.glb", BakeSettings{"octahedral", 8, 0}},
      {kAssets / "props_pbr/Box/glTF-Binary/Box.glb", BakeSettings{"octahedral", 10, 0}},
  };
  absl::StatusOr<std::vector<BatchSubmission>> r = client_->SubmitBakeBatch(items, nullptr);
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_TRUE((*r)[0].status.ok()) << (*r)[0].status;
  ASSERT_TRUE((*r)[1].status.ok()) << (*r)[1].status;
  EXPECT_EQ((*r)[0].result.upload.uploaded, 2) << "uploaded, lost, uploaded again";
  EXPECT_EQ((*r)[1].result.upload.uploaded, 0) << "the blob is back by then";
}

// The server's error reason (trailing metadata) reaches RpcErrorInfo
// unchanged, whatever the message says.
TEST_F(FakeServerTest, ServerErrorReasonReachesRpcErrorInfo) {
  {
    std::lock_guard lock(fake_.mu);
    fake_.submit_refusal_reason = "TOKEN_PENDING_JOBS";
  }
  absl::StatusOr<SubmitResult> r =
      client_->SubmitBake(kAssets / "props_pbr/Box/glTF-Binary/Box.glb", BakeSettings{"octahedral", 8, 0});
  ASSERT_EQ(r.status().code(), absl::StatusCode::kResourceExhausted) << r.status();
  std::optional<RpcErrorInfo> info = GetRpcErrorInfo(r.status());
  ASSERT_TRUE(info.has_value());
  EXPECT_EQ(info->reason, "TOKEN_PENDING_JOBS");
  EXPECT_EQ(info->server_message, "reworded: the queue is full");
}

TEST_F(FakeServerTest, FetchWritesVerifiedFilesThenReusesThem) {
  const std::string key = AddResult();
  absl::StatusOr<FetchResult> r = client_->Fetch(key, dir_);
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->manifest_path, dir_ / "manifest.json");
  ASSERT_EQ(r->files.size(), 3u);
  EXPECT_EQ(r->files.back(), dir_ / "manifest.json");
  for (const auto& [name, bytes] : contents_) EXPECT_EQ(ReadAll(dir_ / name), bytes) << name;
  EXPECT_EQ(r->bytes_downloaded, 5000 + 3500 + static_cast<int64_t>(contents_["manifest.json"].size()));
  EXPECT_EQ(r->bytes_reused, 0);

  absl::StatusOr<FetchResult> again = client_->Fetch(key, dir_);
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_EQ(again->bytes_downloaded, 0);
  EXPECT_EQ(again->bytes_reused, r->bytes_downloaded);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 3);
}

TEST_F(FakeServerTest, FetchReplacesAStaleFile) {
  const std::string key = AddResult();
  fs::create_directories(dir_);
  std::ofstream(dir_ / "albedo_alpha.png") << "stale";
  absl::StatusOr<FetchResult> r = client_->Fetch(key, dir_);
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(ReadAll(dir_ / "albedo_alpha.png"), contents_["albedo_alpha.png"]);
}

TEST_F(FakeServerTest, AFailedFetchIntoAnotherResultsFolderLeavesNoManifestThatLies) {
  const std::string key = AddResult();
  fs::create_directories(dir_);
  std::ofstream(dir_ / "manifest.json") << "{\"cache_key\": \"an older result\"}";
  std::ofstream(dir_ / "albedo_alpha.png") << "the older result's albedo";
  {
    std::lock_guard lock(fake_.mu);
    fake_.corrupt.insert(Sha256Hex(contents_["normal_depth.png"]));
  }
  absl::StatusOr<FetchResult> r = client_->Fetch(key, dir_);
  ASSERT_EQ(r.status().code(), absl::StatusCode::kDataLoss) << r.status();
  // Files are renamed in only once every one arrived: the failure leaves the
  // folder's maps as they were, and no temporary file behind.
  EXPECT_EQ(ReadAll(dir_ / "albedo_alpha.png"), "the older result's albedo");
  EXPECT_FALSE(fs::exists(dir_ / "manifest.json")) << "the old manifest no longer describes the folder";
  for (const auto& entry : fs::directory_iterator(dir_)) {
    EXPECT_EQ(entry.path().filename().string().find(".part-"), std::string::npos) << entry.path();
  }
}

TEST_F(FakeServerTest, BrokenDownloadResumesFromOffset) {
  const std::string key = AddResult();
  {
    std::lock_guard lock(fake_.mu);
    fake_.break_once.insert(Sha256Hex(contents_["albedo_alpha.png"]));
  }
  absl::StatusOr<FetchResult> r = client_->Fetch(key, dir_);
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(ReadAll(dir_ / "albedo_alpha.png"), contents_["albedo_alpha.png"]);
  std::lock_guard lock(fake_.mu);
  // The first stream sent two 1000-byte chunks before breaking.
  EXPECT_EQ(std::count(fake_.read_offsets.begin(), fake_.read_offsets.end(), 2000), 1);
}

TEST_F(FakeServerTest, CorruptDownloadIsDataLossAndLeavesNothing) {
  const std::string key = AddResult();
  {
    std::lock_guard lock(fake_.mu);
    fake_.corrupt.insert(Sha256Hex(contents_["normal_depth.png"]));
  }
  absl::StatusOr<FetchResult> r = client_->Fetch(key, dir_);
  ASSERT_EQ(r.status().code(), absl::StatusCode::kDataLoss) << r.status();
  EXPECT_NE(r.status().message().find("normal_depth.png"), std::string::npos) << r.status();
  EXPECT_FALSE(fs::exists(dir_ / "normal_depth.png"));
  EXPECT_FALSE(fs::exists(dir_ / "manifest.json"));
  for (const auto& entry : fs::directory_iterator(dir_)) {
    EXPECT_EQ(entry.path().filename(), "albedo_alpha.png") << "left behind: " << entry.path();
  }
}

// Maps download side by side where the machine has cores to spare
// (DefaultParallelDownloads; parallel_fetch_test.cc forces it): with more
// maps than streams every file still arrives whole and in manifest order in `files`,
// one corrupt map fails the fetch before manifest.json is written, and the
// next fetch reuses what was verified.
TEST_F(FakeServerTest, ManyMapsFetchInParallelAndACorruptOneStopsTheManifest) {
  const std::string key = AddResult();
  std::vector<std::string> names;
  {
    std::lock_guard lock(fake_.mu);
    v1::Manifest& m = fake_.results[key];
    for (int i = 0; i < 7; ++i) {
      const std::string name = "extra_" + std::to_string(i) + ".png";
      std::string bytes(3000 + 100 * i, '\0');
      for (size_t j = 0; j < bytes.size(); ++j) bytes[j] = static_cast<char>(j * (i + 3));
      auto* map = m.add_maps();
      map->set_semantic("extra");
      map->set_file(name);
      *map->mutable_digest() = DigestOf(bytes);
      fake_.blobs[Sha256Hex(bytes)] = bytes;
      contents_[name] = bytes;
      names.push_back(name);
    }
    fake_.corrupt.insert(Sha256Hex(contents_["extra_5.png"]));
  }
  absl::StatusOr<FetchResult> bad = client_->Fetch(key, dir_);
  ASSERT_EQ(bad.status().code(), absl::StatusCode::kDataLoss) << bad.status();
  EXPECT_NE(bad.status().message().find("extra_5.png"), std::string::npos) << bad.status();
  EXPECT_FALSE(fs::exists(dir_ / "manifest.json"));
  EXPECT_FALSE(fs::exists(dir_ / "extra_5.png"));
  {
    std::lock_guard lock(fake_.mu);
    fake_.corrupt.clear();
  }
  absl::StatusOr<FetchResult> r = client_->Fetch(key, dir_);
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_EQ(r->files.size(), 10u);
  EXPECT_EQ(r->files[2], dir_ / "extra_0.png") << "files keep the manifest's order";
  EXPECT_EQ(r->files.back(), dir_ / "manifest.json");
  for (const auto& [name, bytes] : contents_) EXPECT_EQ(ReadAll(dir_ / name), bytes) << name;
  int64_t total = 0;
  for (const auto& [name, bytes] : contents_) total += static_cast<int64_t>(bytes.size());
  EXPECT_EQ(r->bytes_downloaded + r->bytes_reused, total);
  EXPECT_GE(r->bytes_downloaded, static_cast<int64_t>(contents_["extra_5.png"].size()));
}

TEST_F(FakeServerTest, UnknownKeyIsNotFound) {
  absl::StatusOr<FetchResult> r = client_->Fetch(std::string(64, 'c'), dir_);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kNotFound) << r.status();
}

TEST_F(FakeServerTest, ManifestNamingAPathOutsideIsRefused) {
  const std::string key = AddResult();
  {
    std::lock_guard lock(fake_.mu);
    fake_.results[key].mutable_maps(0)->set_file("../evil.png");
  }
  absl::StatusOr<FetchResult> r = client_->Fetch(key, dir_ / "sub");
  EXPECT_FALSE(r.ok());
  EXPECT_FALSE(fs::exists(dir_ / "evil.png"));
}

TEST_F(FakeServerTest, GetManifestJson) {
  const std::string key = AddResult();
  absl::StatusOr<std::string> text = client_->GetManifestJson(key);
  ASSERT_TRUE(text.ok()) << text.status();
  EXPECT_EQ(*text, contents_["manifest.json"]);
}

}  // namespace
}  // namespace impostor::sdk
