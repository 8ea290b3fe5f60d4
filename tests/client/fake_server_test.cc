// The SDK against an in-process fake of the impostor.v1 services: an
// in-memory blob store that can break streams and corrupt bytes on demand.
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "client/transport.h"
#include "common/sha256.h"
#include "impostor/client.h"
#include "impostor/v1/asset_service.grpc.pb.h"
#include "impostor/v1/bake_service.grpc.pb.h"

namespace impostor::sdk {
namespace {

namespace fs = std::filesystem;

const fs::path kAssets = IMPOSTOR_ASSETS_DIR;

v1::Digest DigestOf(const std::string& bytes) {
  v1::Digest d;
  d.set_hash(Sha256Hex(bytes));
  d.set_size_bytes(static_cast<int64_t>(bytes.size()));
  return d;
}

std::string ReadAll(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

class FakeServer final : public v1::AssetService::Service, public v1::BakeService::Service {
 public:
  // Test knobs and observations; guarded by mu.
  std::mutex mu;
  std::map<std::string, std::string> blobs;  // hash -> bytes
  std::map<std::string, v1::Manifest> results;
  std::vector<std::string> uploaded;           // hashes, in order
  std::vector<int64_t> read_offsets;           // every ReadBlob request's offset
  std::map<std::string, std::vector<int64_t>> read_offsets_by_hash;  // the same per blob (maps download in parallel)
  std::set<std::string> break_once;            // hashes whose first ReadBlob breaks midway
  std::set<std::string> corrupt;               // hashes served with a flipped byte
  int64_t refuse_uploads_over = 0;              // > 0: larger uploads get RESOURCE_EXHAUSTED (a full disk)
  size_t chunk = 1000;                         // ReadBlob chunk size
  v1::SubmitBakeRequest last_submit;
  std::vector<std::vector<v1::Job>> watch_scripts;  // one per WatchJob call; UNAVAILABLE after a script
  int watch_calls = 0;
  v1::Job get_job;                             // GetJob's answer
  int find_missing_calls = 0;
  std::vector<v1::SubmitBakeRequest> submits;  // every SubmitBake, in order
  // Outage knobs: the next N calls of each kind fail with UNAVAILABLE, as a
  // server that is down would answer, before they are served normally.
  int get_job_unavailable = 0;
  int submit_unavailable = 0;
  // When set, SubmitBake refuses with RESOURCE_EXHAUSTED and this error
  // reason (trailing metadata impostor-error-reason).
  std::string submit_refusal_reason;
  // The next N SubmitBake calls first forget every blob (an eviction between
  // upload and submit); a missing blob is refused as the server refuses it,
  // with the reason INPUT_BLOB_MISSING unless missing_blob_reason is false
  // (a server from before the reasons).
  int submit_evicts = 0;
  bool missing_blob_reason = true;
  int upload_unavailable = 0;
  int read_unavailable = 0;
  int refuse_after_break = 0;  // read_unavailable once a break_once stream broke
  int watch_unavailable = 0;
  bool watch_ends_ok = false;  // every script ends OK (a server shutting down politely)
  // GetJob answers this code instead (OK = answer get_job).
  grpc::StatusCode get_job_code = grpc::StatusCode::OK;
  int get_job_calls = 0;
  int upload_calls = 0;

  // Takes one failure from `budget` if any is left.
  static bool Fail(int& budget) {
    if (budget <= 0) return false;
    --budget;
    return true;
  }
  static grpc::Status Down() { return {grpc::StatusCode::UNAVAILABLE, "server down (test)"}; }

  grpc::Status FindMissingBlobs(grpc::ServerContext*, const v1::FindMissingBlobsRequest* req,
                                v1::FindMissingBlobsResponse* resp) override {
    std::lock_guard lock(mu);
    ++find_missing_calls;
    for (const auto& d : req->digests()) {
      if (!blobs.contains(d.hash())) *resp->add_missing() = d;
    }
    return grpc::Status::OK;
  }

  grpc::Status UploadBlob(grpc::ServerContext*, grpc::ServerReader<v1::UploadBlobRequest>* reader,
                          v1::UploadBlobResponse* resp) override {
    {
      std::lock_guard lock(mu);
      ++upload_calls;
      if (Fail(upload_unavailable)) return Down();
    }
    v1::UploadBlobRequest msg;
    v1::Digest digest;
    std::string data;
    bool first = true;
    while (reader->Read(&msg)) {
      if (first) digest = msg.digest();
      first = false;
      if (msg.data().size() > (4u << 20)) return {grpc::StatusCode::INVALID_ARGUMENT, "chunk too large"};
      data += msg.data();
    }
    if (first) return {grpc::StatusCode::INVALID_ARGUMENT, "no digest"};
    {
      std::lock_guard lock(mu);
      if (refuse_uploads_over > 0 && static_cast<int64_t>(data.size()) > refuse_uploads_over) {
        return {grpc::StatusCode::RESOURCE_EXHAUSTED, "cannot store the blob: No space left on device"};
      }
    }
    if (Sha256Hex(data) != digest.hash() || static_cast<int64_t>(data.size()) != digest.size_bytes()) {
      return {grpc::StatusCode::INVALID_ARGUMENT, "hash mismatch"};
    }
    std::lock_guard lock(mu);
    resp->set_already_present(blobs.contains(digest.hash()));
    blobs[digest.hash()] = data;
    uploaded.push_back(digest.hash());
    *resp->mutable_digest() = digest;
    return grpc::Status::OK;
  }

  grpc::Status ReadBlob(grpc::ServerContext*, const v1::ReadBlobRequest* req,
                        grpc::ServerWriter<v1::ReadBlobResponse>* writer) override {
    std::string bytes;
    bool breaks = false;
    size_t chunk_size;
    {
      std::lock_guard lock(mu);
      read_offsets.push_back(req->offset());
      read_offsets_by_hash[req->digest().hash()].push_back(req->offset());
      if (Fail(read_unavailable)) return Down();
      auto it = blobs.find(req->digest().hash());
      if (it == blobs.end()) return {grpc::StatusCode::NOT_FOUND, "no such blob"};
      bytes = it->second;
      if (corrupt.contains(req->digest().hash())) bytes[bytes.size() / 2] ^= 0x5a;
      breaks = break_once.erase(req->digest().hash()) > 0;
      chunk_size = chunk;
    }
    if (req->offset() < 0 || req->offset() > static_cast<int64_t>(bytes.size())) {
      return {grpc::StatusCode::INVALID_ARGUMENT, "offset beyond the end"};
    }
    int sent = 0;
    for (size_t off = static_cast<size_t>(req->offset()); off < bytes.size(); off += chunk_size) {
      if (breaks && sent == 2) {
        std::lock_guard lock(mu);
        read_unavailable = refuse_after_break;
        return {grpc::StatusCode::UNAVAILABLE, "connection reset (test)"};
      }
      v1::ReadBlobResponse msg;
      msg.set_offset(static_cast<int64_t>(off));
      msg.set_data(bytes.substr(off, chunk_size));
      if (!writer->Write(msg)) return grpc::Status::CANCELLED;
      ++sent;
    }
    return grpc::Status::OK;
  }

  grpc::Status GetResult(grpc::ServerContext*, const v1::GetResultRequest* req, v1::Manifest* resp) override {
    std::lock_guard lock(mu);
    auto it = results.find(req->cache_key());
    if (it == results.end()) return {grpc::StatusCode::NOT_FOUND, "nothing baked under that key"};
    *resp = it->second;
    return grpc::Status::OK;
  }

  grpc::Status SubmitBake(grpc::ServerContext* context, const v1::SubmitBakeRequest* req,
                          v1::SubmitBakeResponse* resp) override {
    std::lock_guard lock(mu);
    last_submit = *req;
    submits.push_back(*req);
    if (Fail(submit_unavailable)) return Down();
    if (!submit_refusal_reason.empty()) {
      context->AddTrailingMetadata("impostor-error-reason", submit_refusal_reason);
      return {grpc::StatusCode::RESOURCE_EXHAUSTED, "reworded: the queue is full"};
    }
    if (req->parameters().frames() > 64) {
      return {grpc::StatusCode::INVALID_ARGUMENT, "parameters.frames: 80 is out of range 2..64"};
    }
    if (Fail(submit_evicts)) blobs.clear();
    auto missing = [&](const v1::InputFile& f) -> grpc::Status {
      if (missing_blob_reason) context->AddTrailingMetadata("impostor-error-reason", "INPUT_BLOB_MISSING");
      return {grpc::StatusCode::FAILED_PRECONDITION, f.path() + ": blob is not in the store; upload it first"};
    };
    if (!blobs.contains(req->mesh().entry().digest().hash())) return missing(req->mesh().entry());
    for (const auto& f : req->mesh().files()) {
      if (!blobs.contains(f.digest().hash())) return missing(f);
    }
    resp->set_job_id("job-1");
    resp->set_cache_key(std::string(64, 'a'));
    return grpc::Status::OK;
  }

  grpc::Status WatchJob(grpc::ServerContext*, const v1::WatchJobRequest*,
                        grpc::ServerWriter<v1::Job>* writer) override {
    std::vector<v1::Job> script;
    bool last_script;
    {
      std::lock_guard lock(mu);
      if (Fail(watch_unavailable)) return Down();
      if (watch_calls >= static_cast<int>(watch_scripts.size())) return {grpc::StatusCode::NOT_FOUND, "no job"};
      script = watch_scripts[watch_calls++];
      last_script = watch_calls == static_cast<int>(watch_scripts.size());
    }
    for (const v1::Job& job : script) writer->Write(job);
    if (!last_script && !watch_ends_ok) return {grpc::StatusCode::UNAVAILABLE, "server restarting (test)"};
    return grpc::Status::OK;
  }

  grpc::Status GetJob(grpc::ServerContext*, const v1::GetJobRequest*, v1::Job* resp) override {
    std::lock_guard lock(mu);
    ++get_job_calls;
    if (Fail(get_job_unavailable)) return Down();
    if (get_job_code != grpc::StatusCode::OK) return {get_job_code, "refused (test)"};
    *resp = get_job;
    return grpc::Status::OK;
  }
};

class FakeServerTest : public testing::Test {
 protected:
  void SetUp() override {
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port_);
    builder.RegisterService(static_cast<v1::AssetService::Service*>(&fake_));
    builder.RegisterService(static_cast<v1::BakeService::Service*>(&fake_));
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    ClientOptions options;
    options.server = "127.0.0.1:" + std::to_string(port_);
    options.connect_timeout_seconds = 5;
    auto client = Client::Connect(options);
    ASSERT_TRUE(client.ok()) << client.status();
    client_ = std::move(*client);
    dir_ = fs::temp_directory_path() / ("impostor_fake_server_" + std::to_string(::getpid()) + "_" +
                                        testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
  }
  // A client of the fake with `options` (server filled in). Budget tests use
  // max_attempts 2, so that only the outage budget can carry a call through
  // more failures than that.
  std::unique_ptr<Client> Connect(int max_attempts, double max_outage_seconds,
                                  std::function<void(const ConnectionEvent&)> on_connection_change = nullptr) {
    ClientOptions options;
    options.max_attempts = max_attempts;
    options.max_outage_seconds = max_outage_seconds;
    options.on_connection_change = std::move(on_connection_change);
    options.server = "127.0.0.1:" + std::to_string(port_);
    auto client = Client::Connect(options);
    EXPECT_TRUE(client.ok()) << client.status();
    return client.ok() ? std::move(*client) : nullptr;
  }

  void TearDown() override {
    client_.reset();
    server_->Shutdown();
    fs::remove_all(dir_);
  }

  // Stores a result with two maps and its manifest.json; returns the key.
  std::string AddResult(const std::string& key = std::string(64, 'b')) {
    std::string albedo(5000, '\0'), normal(3500, '\0');
    for (size_t i = 0; i < albedo.size(); ++i) albedo[i] = static_cast<char>(i * 7);
    for (size_t i = 0; i < normal.size(); ++i) normal[i] = static_cast<char>(i * 13);
    const std::string manifest_json = "{\"format_version\": 1}\n";
    v1::Manifest m;
    m.set_cache_key(key);
    auto* a = m.add_maps();
    a->set_semantic("albedo_alpha");
    a->set_file("albedo_alpha.png");
    *a->mutable_digest() = DigestOf(albedo);
    auto* n = m.add_maps();
    n->set_semantic("normal_depth");
    n->set_file("normal_depth.png");
    *n->mutable_digest() = DigestOf(normal);
    *m.mutable_manifest_json() = DigestOf(manifest_json);
    std::lock_guard lock(fake_.mu);
    for (const std::string& b : {albedo, normal, manifest_json}) fake_.blobs[Sha256Hex(b)] = b;
    fake_.results[key] = m;
    contents_ = {{"albedo_alpha.png", albedo}, {"normal_depth.png", normal}, {"manifest.json", manifest_json}};
    return key;
  }

  FakeServer fake_;
  int port_ = 0;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<Client> client_;
  fs::path dir_;
  std::map<std::string, std::string> contents_;
};

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
  EXPECT_EQ(ReadAll(dir_ / "albedo_alpha.png"), contents_["albedo_alpha.png"]) << "replaced before the failure";
  EXPECT_FALSE(fs::exists(dir_ / "manifest.json")) << "the old manifest no longer describes the maps";
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

// Maps download side by side (at most 4 streams): with more maps than
// streams every file still arrives whole and in manifest order in `files`,
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

v1::Job MakeJob(v1::JobState state, float progress, const std::string& stage) {
  v1::Job j;
  j.set_job_id("job-1");
  j.set_cache_key(std::string(64, 'a'));
  j.set_state(state);
  j.set_progress(progress);
  j.set_stage(stage);
  return j;
}

TEST_F(FakeServerTest, WatchResumesAfterBrokenStream) {
  {
    std::lock_guard lock(fake_.mu);
    fake_.watch_scripts = {
        {MakeJob(v1::JOB_STATE_QUEUED, 0, ""), MakeJob(v1::JOB_STATE_RUNNING, 0.1f, "render")},
        {MakeJob(v1::JOB_STATE_RUNNING, 0.5f, "render"), MakeJob(v1::JOB_STATE_SUCCEEDED, 1, "")},
    };
    fake_.get_job = MakeJob(v1::JOB_STATE_RUNNING, 0.5f, "render");
  }
  std::vector<JobUpdate> seen;
  absl::StatusOr<JobUpdate> done = client_->WatchJob("job-1", [&](const JobUpdate& u) { seen.push_back(u); });
  ASSERT_TRUE(done.ok()) << done.status();
  EXPECT_EQ(done->state, JobState::kSucceeded);
  // queued, running 10%, running 50% (from GetJob; the new stream's repeat is
  // dropped), succeeded.
  ASSERT_EQ(seen.size(), 4u);
  EXPECT_EQ(seen[0].state, JobState::kQueued);
  EXPECT_EQ(seen[2].progress, 0.5);
  EXPECT_EQ(seen[3].state, JobState::kSucceeded);
}

TEST_F(FakeServerTest, WatchReportsFailedBakeAsState) {
  v1::Job failed = MakeJob(v1::JOB_STATE_FAILED, 0.2f, "load");
  failed.mutable_error()->set_code(3);
  failed.mutable_error()->set_message("mesh: no triangles");
  {
    std::lock_guard lock(fake_.mu);
    fake_.watch_scripts = {{failed}};
  }
  absl::StatusOr<JobUpdate> done = client_->WatchJob("job-1", nullptr);
  ASSERT_TRUE(done.ok()) << done.status();
  EXPECT_EQ(done->state, JobState::kFailed);
  EXPECT_EQ(done->error_code, 3);
  EXPECT_EQ(done->error_message, "mesh: no triangles");
}

TEST_F(FakeServerTest, WatchUnknownJobIsNotFound) {
  absl::StatusOr<JobUpdate> done = client_->WatchJob("nope", nullptr);
  EXPECT_EQ(done.status().code(), absl::StatusCode::kNotFound) << done.status();
}

// Records ClientOptions::on_connection_change events.
struct EventLog {
  std::mutex mu;
  std::vector<ConnectionEvent> events;
  std::function<void(const ConnectionEvent&)> Callback() {
    return [this](const ConnectionEvent& e) {
      std::lock_guard lock(mu);
      events.push_back(e);
    };
  }
  int Count(ConnectionEvent::Kind kind) {
    std::lock_guard lock(mu);
    return static_cast<int>(std::count_if(events.begin(), events.end(), [&](const auto& e) { return e.kind == kind; }));
  }
};

// The outage outlasts max_attempts (2) on every step of a watch: the broken
// stream, the GetJob that follows and the next stream. The old SDK returned
// the first failed GetJob here.
// A retry's backoff during an outage waits on the channel, which is what
// drives a sync channel's reconnection: a server back on its port is found
// as soon as it listens, not at the next backup poll (every 5 s), which a
// 500-asset batch waited out 2-5 s after every restart.
TEST_F(FakeServerTest, WaitForServerReturnsOnceARestartedServerListens) {
  ClientOptions options;
  options.server = "127.0.0.1:" + std::to_string(port_);
  auto transport = Transport::Connect(options);
  ASSERT_TRUE(transport.ok()) << transport.status();
  server_->Shutdown();
  server_.reset();
  // Down: the whole wait (the channel cannot connect).
  const auto down_start = std::chrono::steady_clock::now();
  (*transport)->WaitForServer(std::chrono::milliseconds(300));
  EXPECT_GE(std::chrono::steady_clock::now() - down_start, std::chrono::milliseconds(300));

  constexpr auto kLongWait = std::chrono::seconds(60);
  std::atomic<bool> waited{false};
  std::chrono::steady_clock::duration waited_for{};
  std::thread waiter([&] {
    const auto start = std::chrono::steady_clock::now();
    (*transport)->WaitForServer(kLongWait);
    waited_for = std::chrono::steady_clock::now() - start;
    waited = true;
  });
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort("127.0.0.1:" + std::to_string(port_), grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(static_cast<v1::AssetService::Service*>(&fake_));
  builder.RegisterService(static_cast<v1::BakeService::Service*>(&fake_));
  server_ = builder.BuildAndStart();
  ASSERT_NE(server_, nullptr);
  ASSERT_EQ(port, port_);
  waiter.join();
  EXPECT_TRUE(waited.load());
  EXPECT_LT(waited_for, kLongWait) << "returned once connected, not at the end of its wait";
  // Connected: a call goes through at once.
  absl::StatusOr<v1::Job> job = (*transport)->GetJob("job-1");
  EXPECT_NE(job.status().code(), absl::StatusCode::kUnavailable) << job.status();

  // Up and connected: a server that answers UNAVAILABLE is not hammered,
  // the backoff is waited in full.
  const auto up_start = std::chrono::steady_clock::now();
  (*transport)->WaitForServer(std::chrono::milliseconds(200));
  EXPECT_GE(std::chrono::steady_clock::now() - up_start, std::chrono::milliseconds(200));
}

TEST_F(FakeServerTest, WatchRidesOutAnOutageLongerThanItsAttempts) {
  {
    std::lock_guard lock(fake_.mu);
    fake_.watch_scripts = {
        {MakeJob(v1::JOB_STATE_QUEUED, 0, ""), MakeJob(v1::JOB_STATE_RUNNING, 0.1f, "render")},
        {MakeJob(v1::JOB_STATE_RUNNING, 0.5f, "render"), MakeJob(v1::JOB_STATE_SUCCEEDED, 1, "")},
    };
    fake_.get_job = MakeJob(v1::JOB_STATE_RUNNING, 0.5f, "render");
    fake_.get_job_unavailable = 4;
  }
  EventLog log;
  auto client = Connect(2, 60, log.Callback());
  ASSERT_NE(client, nullptr);
  std::vector<JobUpdate> seen;
  absl::StatusOr<JobUpdate> done = client->WatchJob("job-1", [&](const JobUpdate& u) { seen.push_back(u); });
  ASSERT_TRUE(done.ok()) << done.status();
  EXPECT_EQ(done->state, JobState::kSucceeded);
  ASSERT_FALSE(seen.empty());
  EXPECT_EQ(seen.back().state, JobState::kSucceeded);
  {
    std::lock_guard lock(fake_.mu);
    EXPECT_EQ(fake_.get_job_calls, 5) << "four refused, then answered";
    EXPECT_EQ(fake_.watch_calls, 2);
  }
  // One outage, reported once each way however many calls saw it.
  EXPECT_EQ(log.Count(ConnectionEvent::Kind::kLost), 1);
  EXPECT_EQ(log.Count(ConnectionEvent::Kind::kRegained), 1);
  std::lock_guard lock(log.mu);
  ASSERT_EQ(log.events.size(), 2u);
  EXPECT_EQ(log.events[0].kind, ConnectionEvent::Kind::kLost);
  EXPECT_EQ(log.events[0].error.code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(log.events[0].server, "127.0.0.1:" + std::to_string(port_));
  EXPECT_EQ(log.events[0].max_outage_seconds, 60);
  EXPECT_EQ(log.events[1].kind, ConnectionEvent::Kind::kRegained);
  EXPECT_GT(log.events[1].outage_seconds, 0);
}

TEST_F(FakeServerTest, WatchResumesWhenNewStreamsAreRefusedToo) {
  {
    std::lock_guard lock(fake_.mu);
    // The first stream breaks; the next three end at once with UNAVAILABLE
    // (empty scripts), more than max_attempts in a row without news.
    fake_.watch_scripts = {{MakeJob(v1::JOB_STATE_RUNNING, 0.1f, "render")}, {}, {}, {},
                           {MakeJob(v1::JOB_STATE_SUCCEEDED, 1, "")}};
    fake_.get_job = MakeJob(v1::JOB_STATE_RUNNING, 0.1f, "render");
  }
  auto client = Connect(2, 60);
  ASSERT_NE(client, nullptr);
  absl::StatusOr<JobUpdate> done = client->WatchJob("job-1", nullptr);
  ASSERT_TRUE(done.ok()) << done.status();
  EXPECT_EQ(done->state, JobState::kSucceeded);
  std::lock_guard lock(fake_.mu);
  EXPECT_EQ(fake_.watch_calls, 5);
}

// Streams that end without news while the server answers are no outage:
// max_attempts of them in a row end the watch, as an RPC error.
TEST_F(FakeServerTest, WatchGivesUpOnStreamsThatEndWithoutNews) {
  {
    std::lock_guard lock(fake_.mu);
    fake_.watch_scripts = {{MakeJob(v1::JOB_STATE_RUNNING, 0.1f, "render")}, {}, {}, {}};
    fake_.watch_ends_ok = true;
    fake_.get_job = MakeJob(v1::JOB_STATE_RUNNING, 0.1f, "render");
  }
  auto client = Connect(2, 60);
  ASSERT_NE(client, nullptr);
  absl::StatusOr<JobUpdate> done = client->WatchJob("job-1", nullptr);
  ASSERT_EQ(done.status().code(), absl::StatusCode::kUnavailable) << done.status();
  std::optional<RpcErrorInfo> info = GetRpcErrorInfo(done.status());
  ASSERT_TRUE(info.has_value()) << done.status();
  EXPECT_EQ(info->rpc, "WatchJob");
  EXPECT_NE(info->server_message.find("ended before the job finished"), std::string::npos) << done.status();
  std::lock_guard lock(fake_.mu);
  EXPECT_EQ(fake_.watch_calls, 2) << "the stream with news and its end count as one failure, the empty one as the second";
}

TEST_F(FakeServerTest, OutageBudgetSpentReturnsTheLastUnavailable) {
  {
    std::lock_guard lock(fake_.mu);
    fake_.get_job_unavailable = 1 << 30;  // never back
  }
  EventLog log;
  auto client = Connect(1, 2, log.Callback());
  ASSERT_NE(client, nullptr);
  absl::StatusOr<JobUpdate> job = client->GetJob("job-1");
  ASSERT_EQ(job.status().code(), absl::StatusCode::kUnavailable) << job.status();
  EXPECT_NE(job.status().message().find("GetJob"), std::string::npos) << job.status();
  EXPECT_NE(job.status().message().find("server down (test)"), std::string::npos) << job.status();
  {
    std::lock_guard lock(fake_.mu);
    EXPECT_GT(fake_.get_job_calls, 1) << "max_attempts is 1: only the outage budget retries";
  }
  EXPECT_EQ(log.Count(ConnectionEvent::Kind::kLost), 1);
  EXPECT_EQ(log.Count(ConnectionEvent::Kind::kRegained), 0);
}

TEST_F(FakeServerTest, ZeroOutageBudgetTriesMaxAttemptsOnly) {
  {
    std::lock_guard lock(fake_.mu);
    fake_.get_job_unavailable = 1 << 30;
  }
  auto client = Connect(3, 0);
  ASSERT_NE(client, nullptr);
  EXPECT_EQ(client->GetJob("job-1").status().code(), absl::StatusCode::kUnavailable);
  std::lock_guard lock(fake_.mu);
  EXPECT_EQ(fake_.get_job_calls, 3);
}

TEST_F(FakeServerTest, ErrorsOtherThanUnavailableAreNotRetried) {
  const std::vector<grpc::StatusCode> codes = {
      grpc::StatusCode::NOT_FOUND,         grpc::StatusCode::INVALID_ARGUMENT,   grpc::StatusCode::FAILED_PRECONDITION,
      grpc::StatusCode::PERMISSION_DENIED, grpc::StatusCode::RESOURCE_EXHAUSTED, grpc::StatusCode::INTERNAL,
      grpc::StatusCode::DATA_LOSS,         grpc::StatusCode::UNAUTHENTICATED};
  auto client = Connect(5, 60);
  ASSERT_NE(client, nullptr);
  for (grpc::StatusCode code : codes) {
    {
      std::lock_guard lock(fake_.mu);
      fake_.get_job_code = code;
      fake_.get_job_calls = 0;
    }
    absl::StatusOr<JobUpdate> job = client->GetJob("job-1");
    EXPECT_EQ(static_cast<int>(job.status().code()), static_cast<int>(code)) << "code " << code;
    std::lock_guard lock(fake_.mu);
    EXPECT_EQ(fake_.get_job_calls, 1) << "code " << code << " was retried";
  }
}

TEST_F(FakeServerTest, RetriedSubmitSendsTheSameRequestId) {
  const fs::path model = kAssets / "props_pbr/Box/glTF-Binary/Box.glb";
  {
    std::lock_guard lock(fake_.mu);
    fake_.submit_unavailable = 3;
  }
  auto client = Connect(2, 60);
  ASSERT_NE(client, nullptr);
  absl::StatusOr<SubmitResult> r = client->SubmitBake(model, {});
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_TRUE(client->SubmitBake(model, {}).ok());
  std::lock_guard lock(fake_.mu);
  ASSERT_EQ(fake_.submits.size(), 5u) << "three refused, one accepted, then a second submit";
  const std::string id = fake_.submits[0].request_id();
  EXPECT_EQ(id.size(), 32u) << id;
  EXPECT_EQ(id.find_first_not_of("0123456789abcdef"), std::string::npos) << id;
  for (size_t i = 1; i < 4; ++i) EXPECT_EQ(fake_.submits[i].request_id(), id) << "retry " << i;
  EXPECT_NE(fake_.submits[4].request_id(), id) << "a new logical submit gets a new id";
  EXPECT_EQ(fake_.submits[4].request_id().size(), 32u);
}

TEST_F(FakeServerTest, BatchItemsGetDistinctRequestIdsKeptOnRetry) {
  const fs::path box = kAssets / "props_pbr/Box/glTF-Binary/Box.glb";
  {
    std::lock_guard lock(fake_.mu);
    fake_.submit_unavailable = 1;  // the first item's first try
  }
  auto client = Connect(1, 60);
  ASSERT_NE(client, nullptr);
  absl::StatusOr<std::vector<BatchSubmission>> r = client->SubmitBakeBatch({{box, {}}, {box, {}}, {box, {}}}, nullptr);
  ASSERT_TRUE(r.ok()) << r.status();
  for (const BatchSubmission& b : *r) EXPECT_TRUE(b.status.ok()) << b.status;
  std::lock_guard lock(fake_.mu);
  ASSERT_EQ(fake_.submits.size(), 4u);
  EXPECT_EQ(fake_.submits[0].request_id(), fake_.submits[1].request_id()) << "the retry of item 0";
  std::set<std::string> ids;
  for (const auto& submit : fake_.submits) ids.insert(submit.request_id());
  EXPECT_EQ(ids.size(), 3u) << "one id per item";
}

TEST_F(FakeServerTest, UploadStartsOverThroughAnOutage) {
  const fs::path model = kAssets / "props_pbr/Box/glTF-Binary/Box.glb";
  {
    std::lock_guard lock(fake_.mu);
    fake_.upload_unavailable = 4;
  }
  auto client = Connect(2, 60);
  ASSERT_NE(client, nullptr);
  absl::StatusOr<SubmitResult> r = client->SubmitBake(model, {});
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->upload.uploaded, 1);
  std::lock_guard lock(fake_.mu);
  EXPECT_EQ(fake_.upload_calls, 5);
  ASSERT_EQ(fake_.uploaded.size(), 1u);
  EXPECT_EQ(fake_.blobs.at(fake_.uploaded[0]), ReadAll(model)) << "the stored blob is the whole file";
}

TEST_F(FakeServerTest, DownloadResumesAtItsOffsetAfterAnOutage) {
  const std::string key = AddResult();
  {
    std::lock_guard lock(fake_.mu);
    // The albedo map's stream breaks after two 1000-byte chunks; then the
    // server refuses four ReadBlobs, twice max_attempts.
    fake_.break_once.insert(Sha256Hex(contents_["albedo_alpha.png"]));
    fake_.refuse_after_break = 4;
  }
  auto client = Connect(2, 60);
  ASSERT_NE(client, nullptr);
  absl::StatusOr<FetchResult> r = client->Fetch(key, dir_);
  ASSERT_TRUE(r.ok()) << r.status();
  for (const auto& [name, bytes] : contents_) EXPECT_EQ(ReadAll(dir_ / name), bytes) << name;
  std::lock_guard lock(fake_.mu);
  // The albedo map's requests: from 0, then from 2000 on every retry.
  // (Refusals may land on the other map's stream too, so the albedo map
  // gets at least one retry from 2000 and never one from elsewhere.)
  const std::vector<int64_t>& albedo = fake_.read_offsets_by_hash[Sha256Hex(contents_["albedo_alpha.png"])];
  ASSERT_GE(albedo.size(), 2u);
  EXPECT_EQ(albedo.front(), 0);
  EXPECT_EQ(albedo.back(), 2000) << "the last, successful request resumed at 2000";
  for (size_t i = 1; i < albedo.size(); ++i) EXPECT_EQ(albedo[i], 2000) << "request " << i;
}

struct CliRun {
  int exit_code;
  std::string out;  // stdout
  std::string err;  // stderr
};

// Runs the `impostor` tool against the fake server.
CliRun RunCli(const std::string& args, const fs::path& scratch) {
  fs::create_directories(scratch);
  const fs::path out = scratch / "cli.stdout", err = scratch / "cli.stderr";
  const std::string command = std::string(IMPOSTOR_CLI_PATH) + " " + args + " >" + out.string() + " 2>" + err.string();
  const int status = std::system(command.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, ReadAll(out), ReadAll(err)};
}

TEST_F(FakeServerTest, CliBakeUploadsWatchesFetchesAndPrintsJson) {
  AddResult(std::string(64, 'a'));  // the key the fake's SubmitBake answers
  {
    std::lock_guard lock(fake_.mu);
    fake_.watch_scripts = {{MakeJob(v1::JOB_STATE_QUEUED, 0, ""), MakeJob(v1::JOB_STATE_RUNNING, 0.42f, "render"),
                            MakeJob(v1::JOB_STATE_SUCCEEDED, 1, "")}};
  }
  const fs::path out_dir = dir_ / "atlas";
  CliRun run = RunCli("bake " + (kAssets / "props_pbr/Box/glTF-Binary/Box.glb").string() + " --out " +
                          out_dir.string() + " --server 127.0.0.1:" + std::to_string(port_) + " --json",
                      dir_ / "io");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["job_id"], "job-1");
  EXPECT_EQ(j["cache_key"], std::string(64, 'a'));
  EXPECT_EQ(j["manifest"], (out_dir / "manifest.json").string());
  EXPECT_EQ(j["files"].size(), 3u);
  EXPECT_TRUE(j["error"].is_null());
  EXPECT_GT(j["uploaded_bytes"].get<int64_t>(), 0);
  EXPECT_NE(run.err.find("[running  42%] render"), std::string::npos) << run.err;
  EXPECT_EQ(ReadAll(out_dir / "albedo_alpha.png"), contents_["albedo_alpha.png"]);
}

TEST_F(FakeServerTest, CliBakeRefusedByServerExitsOneWithOneLine) {
  CliRun run = RunCli("bake " + (kAssets / "props_pbr/Box/glTF-Binary/Box.glb").string() + " --out " +
                          (dir_ / "atlas").string() + " --frames 80 --server 127.0.0.1:" + std::to_string(port_),
                      dir_ / "io");
  EXPECT_EQ(run.exit_code, 1);
  // The server's API name becomes the flag the user typed, the API name kept.
  EXPECT_EQ(run.err,
            "impostor: bake failed: INVALID_ARGUMENT: --frames (parameters.frames): 80 is out of range 2..64\n");
}

TEST_F(FakeServerTest, CliFailedBakeExitsOneWithServerReason) {
  v1::Job failed = MakeJob(v1::JOB_STATE_FAILED, 0.2f, "load");
  failed.mutable_error()->set_code(3);
  failed.mutable_error()->set_message("mesh: no triangles");
  {
    std::lock_guard lock(fake_.mu);
    fake_.watch_scripts = {{failed}, {failed}};
  }
  CliRun run = RunCli("bake " + (kAssets / "props_pbr/Box/glTF-Binary/Box.glb").string() + " --out " +
                          (dir_ / "atlas").string() + " --quiet --server 127.0.0.1:" + std::to_string(port_),
                      dir_ / "io");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(run.err, "impostor: bake failed: INVALID_ARGUMENT: mesh: no triangles\n");
  EXPECT_EQ(run.out, "");
  // --json: the same stderr line; the object's error is "CODE: message",
  // without the "bake failed: " the line has.
  CliRun json_run = RunCli("bake " + (kAssets / "props_pbr/Box/glTF-Binary/Box.glb").string() + " --out " +
                               (dir_ / "atlas").string() + " --quiet --json --server 127.0.0.1:" +
                               std::to_string(port_),
                           dir_ / "io");
  EXPECT_EQ(json_run.exit_code, 1);
  EXPECT_EQ(json_run.err, "impostor: bake failed: INVALID_ARGUMENT: mesh: no triangles\n");
  const nlohmann::json j = nlohmann::json::parse(json_run.out, nullptr, /*allow_exceptions=*/false);
  ASSERT_TRUE(j.is_object()) << json_run.out;
  EXPECT_EQ(j["error"], "INVALID_ARGUMENT: mesh: no triangles") << json_run.out;
  EXPECT_EQ(j["exit_code"], 1) << json_run.out;
}

TEST_F(FakeServerTest, CliPrintsOneLineWhenItLosesTheServerAndOneWhenItIsBack) {
  AddResult(std::string(64, 'a'));  // the key the fake's SubmitBake answers
  {
    std::lock_guard lock(fake_.mu);
    fake_.watch_scripts = {{MakeJob(v1::JOB_STATE_RUNNING, 0.1f, "render")}, {MakeJob(v1::JOB_STATE_SUCCEEDED, 1, "")}};
    fake_.get_job = MakeJob(v1::JOB_STATE_RUNNING, 0.1f, "render");
    fake_.get_job_unavailable = 6;  // more than the default max_attempts (5)
  }
  const std::string server = "127.0.0.1:" + std::to_string(port_);
  const std::string model = (kAssets / "props_pbr/Box/glTF-Binary/Box.glb").string();
  CliRun run = RunCli("bake " + model + " --out " + (dir_ / "atlas").string() + " --server " + server +
                          " --max-outage-seconds 60",
                      dir_ / "io");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  std::vector<std::string> lost, back;
  std::istringstream lines(run.err);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("impostor: lost server ", 0) == 0) lost.push_back(line);
    if (line.rfind("impostor: server ", 0) == 0) back.push_back(line);
  }
  ASSERT_EQ(lost.size(), 1u) << run.err;
  EXPECT_EQ(lost[0].rfind("impostor: lost server " + server + " (UNAVAILABLE: ", 0), 0u) << lost[0];
  EXPECT_NE(lost[0].find("; retrying for up to 60 s"), std::string::npos) << lost[0];
  ASSERT_EQ(back.size(), 1u) << run.err;
  EXPECT_EQ(back[0].rfind("impostor: server " + server + " is back after ", 0), 0u) << back[0];
  EXPECT_EQ(ReadAll(dir_ / "atlas" / "albedo_alpha.png"), contents_["albedo_alpha.png"]);

  // --quiet silences both lines.
  {
    std::lock_guard lock(fake_.mu);
    fake_.watch_calls = 0;
    fake_.get_job_unavailable = 2;
  }
  run = RunCli("bake " + model + " --out " + (dir_ / "atlas2").string() + " --server " + server + " --quiet",
               dir_ / "io");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.err, "");
}

}  // namespace
}  // namespace impostor::sdk
