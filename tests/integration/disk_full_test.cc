// A full disk with a real server: its data directory on a small tmpfs that
// the test mounts (as root) and fills by uploads. The failing upload is
// RESOURCE_EXHAUSTED naming the path and the free space and leaves nothing
// behind; reads, result lookups and cache hits go on; once space is freed
// uploads work again without a restart.
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/util/sha256.h"
#include "tests/support/server_process.h"
#include "tests/integration/tmpfs_mount.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

std::string RandomBytes(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::string s(n, '\0');
  for (char& c : s) c = static_cast<char>(rng());
  return s;
}

grpc::Status Upload(testing::ServerProcess& server, const std::string& bytes) {
  return testing::UploadBytes(server.assets(), bytes, testing::DigestOf(bytes));
}

v1::SubmitBakeRequest RequestFor(const v1::Digest& mesh) {
  v1::SubmitBakeRequest r;
  r.mutable_mesh()->mutable_entry()->set_path("model.glb");
  *r.mutable_mesh()->mutable_entry()->mutable_digest() = mesh;
  return r;
}

TEST(DiskFull, AFullDataDirectoryRefusesWritesCleanlyServesReadsAndRecovers) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to mount a tmpfs for the data directory";
  const fs::path mount_dir = testing::NewTempDir("disk_full_mount");
  testing::TmpfsMount tmpfs(mount_dir);
  if (!tmpfs.mounted()) GTEST_SKIP() << "cannot mount a tmpfs on " << mount_dir << ": " << tmpfs.error();
  // Space the test gives back at the end.
  const fs::path filler = mount_dir / "filler";
  std::ofstream(filler, std::ios::binary) << std::string(2 << 20, 'f');
  ASSERT_EQ(fs::file_size(filler), 2u << 20);

  std::optional<testing::ServerProcess> server;
  server.emplace(0, mount_dir / "data", "127.0.0.1:0");
  const fs::path data = server->data_dir();

  // A baked result, recorded by a hand-driven worker, to hit later.
  const std::string mesh_bytes = RandomBytes(1000, 1);
  ASSERT_TRUE(Upload(*server, mesh_bytes).ok());
  const v1::SubmitBakeRequest baked = RequestFor(testing::DigestOf(mesh_bytes));
  std::string cache_key;
  {
    grpc::ClientContext submit_ctx;
    v1::SubmitBakeResponse submitted;
    ASSERT_TRUE(server->bake().SubmitBake(&submit_ctx, baked, &submitted).ok());
    cache_key = submitted.cache_key();
    grpc::ClientContext lease_ctx;
    v1::LeaseJobRequest lease;
    lease.set_worker_id("hand-worker");
    v1::LeaseJobResponse leased;
    ASSERT_TRUE(server->workers().LeaseJob(&lease_ctx, lease, &leased).ok());
    const std::string manifest = "{\"manifest\": 1}";
    const std::string map = RandomBytes(5000, 2);
    ASSERT_TRUE(Upload(*server, manifest).ok());
    ASSERT_TRUE(Upload(*server, map).ok());
    v1::CompleteJobRequest complete;
    complete.set_job_id(leased.job().job_id());
    complete.set_lease_id(leased.job().lease_id());
    complete.mutable_result()->set_cache_key(cache_key);
    *complete.mutable_result()->mutable_manifest_json() = testing::DigestOf(manifest);
    v1::MapFile* file = complete.mutable_result()->add_maps();
    file->set_file("albedo_alpha.png");
    *file->mutable_digest() = testing::DigestOf(map);
    grpc::ClientContext complete_ctx;
    v1::CompleteJobResponse completed;
    ASSERT_TRUE(server->workers().CompleteJob(&complete_ctx, complete, &completed).ok());
  }
  // A mesh uploaded now and submitted once the disk is full.
  const std::string later_bytes = RandomBytes(1000, 3);
  ASSERT_TRUE(Upload(*server, later_bytes).ok());

  // Fill the disk: 1 MiB uploads, then smaller ones, until even 4 KiB fail.
  std::string first_refused;
  grpc::Status refused;
  std::vector<std::string> stored;
  uint32_t seed = 100;
  for (size_t size : {size_t{1} << 20, size_t{64} << 10, size_t{4} << 10}) {
    for (int i = 0; i < 64; ++i) {
      const std::string bytes = RandomBytes(size, seed++);
      const grpc::Status s = Upload(*server, bytes);
      if (s.ok()) {
        stored.push_back(bytes);
        continue;
      }
      if (first_refused.empty()) {
        first_refused = bytes;
        refused = s;
      }
      EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
      break;
    }
  }
  ASSERT_FALSE(first_refused.empty()) << "8 MiB never filled up";
  ASSERT_FALSE(stored.empty());
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.error_message();
  EXPECT_NE(refused.error_message().find(data.string()), std::string::npos) << refused.error_message();
  EXPECT_NE(refused.error_message().find("bytes free on its filesystem"), std::string::npos)
      << refused.error_message();
  std::printf("disk full: %zu blobs stored, then: %s\n", stored.size(), refused.error_message().c_str());

  // Nothing half-written: no temporary file left, every blob whole.
  EXPECT_TRUE(fs::is_empty(data / "tmp")) << "a refused upload left its temporary file";
  int blobs = 0;
  for (const auto& entry : fs::recursive_directory_iterator(data / "cas")) {
    if (!entry.is_regular_file()) continue;
    ++blobs;
    EXPECT_EQ(Sha256Hex(testing::ReadFileBytes(entry.path())), entry.path().filename().string())
        << entry.path() << " is not a whole blob";
  }
  EXPECT_EQ(blobs, static_cast<int>(stored.size()) + 4) << "the stored blobs, the mesh, the manifest, the map";

  // Reads, result lookups and cache hits go on.
  std::string read_back;
  const grpc::Status read = testing::ReadBlob(server->assets(), testing::DigestOf(stored.front()), &read_back);
  EXPECT_TRUE(read.ok()) << read.error_message();
  EXPECT_TRUE(read_back == stored.front()) << "the blob read back differs";
  {
    grpc::ClientContext ctx;
    v1::GetResultRequest request;
    request.set_cache_key(cache_key);
    v1::Manifest manifest;
    const grpc::Status s = server->assets().GetResult(&ctx, request, &manifest);
    EXPECT_TRUE(s.ok()) << s.error_message();
  }
  {
    grpc::ClientContext ctx;
    v1::SubmitBakeResponse hit;
    const grpc::Status s = server->bake().SubmitBake(&ctx, baked, &hit);
    EXPECT_TRUE(s.ok()) << "a cache hit on a full disk: " << s.error_message();
    EXPECT_TRUE(hit.cached());
    EXPECT_EQ(hit.job().result().cache_key(), cache_key);
  }
  // A new job needs a database write: accepted or refused as full, never
  // an internal error (SQLite may still have room in its journal).
  {
    grpc::ClientContext ctx;
    v1::SubmitBakeResponse response;
    const grpc::Status s = server->bake().SubmitBake(&ctx, RequestFor(testing::DigestOf(later_bytes)), &response);
    if (!s.ok()) {
      EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
      EXPECT_NE(s.error_message().find("jobs.sqlite3"), std::string::npos) << s.error_message();
    }
    std::printf("disk full: submit of a new job: %s\n", s.ok() ? "accepted" : s.error_message().c_str());
  }

  // Space comes back: the refused upload goes through, no restart needed.
  fs::remove(filler);
  const grpc::Status again = Upload(*server, first_refused);
  EXPECT_TRUE(again.ok()) << again.error_message();
  {
    grpc::ClientContext ctx;
    v1::SubmitBakeResponse response;
    v1::SubmitBakeRequest request = RequestFor(testing::DigestOf(later_bytes));
    request.set_priority(1);  // not the request above, if that one was accepted
    const grpc::Status s = server->bake().SubmitBake(&ctx, request, &response);
    EXPECT_TRUE(s.ok()) << s.error_message();
  }
  server.reset();  // before the unmount
}

}  // namespace
}  // namespace impostor
