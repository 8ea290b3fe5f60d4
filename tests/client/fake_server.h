// An in-process fake of the impostor.v1 services (an in-memory blob store
// that can break streams and corrupt bytes on demand) and FakeServerTest,
// the fixture of the fake_server*_test.cc files: a fake on a loopback port
// and an SDK client of it.
#ifndef IMPOSTOR_TESTS_CLIENT_FAKE_SERVER_H_
#define IMPOSTOR_TESTS_CLIENT_FAKE_SERVER_H_

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "common/util/sha256.h"
#include "impostor/client.h"
#include "impostor/v1/asset_service.grpc.pb.h"
#include "impostor/v1/bake_service.grpc.pb.h"

// Not in an anonymous namespace: the tests of every fake_server_*_test.cc
// share one FakeServerTest type (GoogleTest requires it of a test suite).
namespace impostor::sdk {

namespace fs = std::filesystem;

inline const fs::path kAssets = IMPOSTOR_ASSETS_DIR;

inline v1::Digest DigestOf(const std::string& bytes) {
  v1::Digest d;
  d.set_hash(Sha256Hex(bytes));
  d.set_size_bytes(static_cast<int64_t>(bytes.size()));
  return d;
}

inline std::string ReadAll(const fs::path& p) {
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
  // > 0: each ReadBlob waits before its first byte until this many ReadBlob
  // streams are open at once (a client fetching one file at a time never
  // gets there: its stream fails ABORTED after 20 s). max_open_reads: the
  // most streams ever open at once.
  int reads_must_overlap = 0;
  // BatchReadBlobs: UNIMPLEMENTED (a server from before the call) unless
  // batch_reads; served blobs take `corrupt` as ReadBlob does.
  bool batch_reads = false;
  int batch_read_calls = 0;
  int batch_read_blobs = 0;  // blobs asked in all of them
  // BatchUpdateBlobs: UNIMPLEMENTED (a server from before the call) unless
  // batch_updates; then batch_update_code (OK: serve it) for the whole call.
  // A blob is stored as UploadBlob stores it, or refused in its slot:
  // INVALID_ARGUMENT when its bytes do not match, RESOURCE_EXHAUSTED
  // (STORE_FULL) when over refuse_uploads_over or in refuse_in_batch.
  bool batch_updates = false;
  grpc::StatusCode batch_update_code = grpc::StatusCode::OK;
  std::set<std::string> refuse_in_batch;  // hashes
  int batch_update_attempts = 0;          // every call, UNIMPLEMENTED ones too
  std::vector<std::vector<std::string>> batch_updates_seen;  // per served call: its hashes
  std::vector<int64_t> batch_update_bytes;                   // per served call: its data bytes
  std::vector<std::string> batch_uploaded;                   // hashes stored through a batch, in order
  int open_reads = 0;
  int max_open_reads = 0;
  std::condition_variable reads_changed;

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
    {
      std::unique_lock lock(mu);
      max_open_reads = std::max(max_open_reads, ++open_reads);
      reads_changed.notify_all();
      const bool overlapped = reads_changed.wait_for(lock, std::chrono::seconds(20), [&] {
        return reads_must_overlap == 0 || max_open_reads >= reads_must_overlap;
      });
      if (!overlapped) {
        --open_reads;
        return {grpc::StatusCode::ABORTED, "the client never had the streams open at once (test)"};
      }
    }
    struct Closed {
      FakeServer* fake;
      ~Closed() {
        std::lock_guard lock(fake->mu);
        --fake->open_reads;
      }
    } closed{this};
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

  grpc::Status BatchReadBlobs(grpc::ServerContext*, const v1::BatchReadBlobsRequest* req,
                              v1::BatchReadBlobsResponse* resp) override {
    std::lock_guard lock(mu);
    if (!batch_reads) return {grpc::StatusCode::UNIMPLEMENTED, "unknown method (test)"};
    ++batch_read_calls;
    for (const v1::Digest& d : req->digests()) {
      ++batch_read_blobs;
      auto* blob = resp->add_blobs();
      *blob->mutable_digest() = d;
      auto it = blobs.find(d.hash());
      if (it == blobs.end()) {
        blob->set_code(static_cast<int>(grpc::StatusCode::NOT_FOUND));
        blob->set_message("no such blob");
        continue;
      }
      std::string bytes = it->second;
      if (corrupt.contains(d.hash()) && !bytes.empty()) bytes[bytes.size() / 2] ^= 0x5a;
      blob->set_data(bytes);
    }
    return grpc::Status::OK;
  }

  grpc::Status BatchUpdateBlobs(grpc::ServerContext*, const v1::BatchUpdateBlobsRequest* req,
                                v1::BatchUpdateBlobsResponse* resp) override {
    std::lock_guard lock(mu);
    ++batch_update_attempts;
    if (!batch_updates) return {grpc::StatusCode::UNIMPLEMENTED, "unknown method (test)"};
    if (batch_update_code != grpc::StatusCode::OK) return {batch_update_code, "the whole batch refused (test)"};
    batch_updates_seen.emplace_back();
    batch_update_bytes.push_back(0);
    for (const v1::BatchUpdateBlobsRequest::Request& blob : req->requests()) {
      const v1::Digest& d = blob.digest();
      batch_updates_seen.back().push_back(d.hash());
      batch_update_bytes.back() += static_cast<int64_t>(blob.data().size());
      auto* answer = resp->add_responses();
      *answer->mutable_digest() = d;
      if (Sha256Hex(blob.data()) != d.hash() || static_cast<int64_t>(blob.data().size()) != d.size_bytes()) {
        answer->set_code(static_cast<int>(grpc::StatusCode::INVALID_ARGUMENT));
        answer->set_message("hash mismatch (test)");
        continue;
      }
      if (refuse_in_batch.contains(d.hash()) ||
          (refuse_uploads_over > 0 && static_cast<int64_t>(blob.data().size()) > refuse_uploads_over)) {
        answer->set_code(static_cast<int>(grpc::StatusCode::RESOURCE_EXHAUSTED));
        answer->set_message("cannot store the blob: No space left on device (test)");
        answer->set_reason("STORE_FULL");
        continue;
      }
      answer->set_already_present(blobs.contains(d.hash()));
      blobs[d.hash()] = blob.data();
      batch_uploaded.push_back(d.hash());
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

// A job as the fake's WatchJob and GetJob answer it.
inline v1::Job MakeJob(v1::JobState state, float progress, const std::string& stage) {
  v1::Job j;
  j.set_job_id("job-1");
  j.set_cache_key(std::string(64, 'a'));
  j.set_state(state);
  j.set_progress(progress);
  j.set_stage(stage);
  return j;
}

}  // namespace impostor::sdk

#endif  // IMPOSTOR_TESTS_CLIENT_FAKE_SERVER_H_
