#include "tests/support/published_result.h"

#include <atomic>
#include <random>

#include <gtest/gtest.h>

#include "common/manifest/manifest_json.h"

namespace impostor::testing {

std::string RandomBytes(int64_t size, uint32_t seed) {
  std::mt19937 rng(seed);
  std::string bytes(static_cast<size_t>(size), '\0');
  for (char& c : bytes) c = static_cast<char>(rng());
  return bytes;
}

PublishedResult CompleteNextJob(ServerProcess& server, const std::vector<int64_t>& map_sizes, uint32_t seed,
                                bool one_blob, uint32_t map_seed) {
  PublishedResult out;
  grpc::ClientContext lease_ctx;
  v1::LeaseJobRequest lease;
  // An id per call: tests publish through tokens of their choosing, and a
  // worker id belongs to the token using it (BakeScheduler::Lease).
  static std::atomic<int> next_worker{0};
  lease.set_worker_id("cache-test-worker-" + std::to_string(next_worker++));
  lease.set_wait_seconds(10);
  v1::LeaseJobResponse leased;
  grpc::Status s = server.workers().LeaseJob(&lease_ctx, lease, &leased);
  EXPECT_TRUE(s.ok()) << s.error_message();
  EXPECT_TRUE(leased.has_job()) << "no job to complete";
  out.key = leased.job().cache_key();

  v1::Manifest manifest;
  manifest.set_format_version(kManifestFormatVersion);
  manifest.set_cache_key(out.key);
  manifest.set_baker_version("cache-test");
  manifest.set_layout(v1::LAYOUT_OCTAHEDRAL);
  manifest.set_frames(leased.job().parameters().frames());
  manifest.set_resolution(leased.job().parameters().resolution());
  manifest.set_tile_size(manifest.resolution() / std::max(1u, manifest.frames()));
  // One view per frame, as every atlas manifest lists them (a game builds
  // the runtime's layout from their count); their contents matter to no test.
  for (uint32_t i = 0; i < manifest.frames() * manifest.frames(); ++i) {
    v1::View* view = manifest.add_views();
    view->set_index(i);
    view->set_same_view_as(i);
  }
  const char* semantics[] = {"albedo_alpha", "normal_depth", "orm"};
  for (size_t i = 0; i < map_sizes.size(); ++i) {
    const uint32_t bytes_seed = map_seed != 0 ? map_seed : seed;
    const std::string bytes =
        RandomBytes(map_sizes[i], bytes_seed * 16 + (one_blob ? 0u : static_cast<uint32_t>(i)) + 1);
    v1::MapFile* map = manifest.add_maps();
    map->set_semantic(semantics[i % 3]);
    map->set_file(std::string(semantics[i % 3]) + ".png");
    *map->mutable_digest() = DigestOf(bytes);
    map->set_width(manifest.resolution());
    map->set_height(manifest.resolution());
    map->set_format(i == 1 ? "png_rgba16" : "png_rgba8");
    s = UploadBytes(server.assets(), bytes, map->digest());
    EXPECT_TRUE(s.ok()) << s.error_message();
    out.files[map->file()] = bytes;
    out.total_bytes += static_cast<int64_t>(bytes.size());
  }
  const std::string json = ManifestToJson(manifest);
  *manifest.mutable_manifest_json() = DigestOf(json);
  s = UploadBytes(server.assets(), json, manifest.manifest_json());
  EXPECT_TRUE(s.ok()) << s.error_message();
  out.files["manifest.json"] = json;
  out.total_bytes += static_cast<int64_t>(json.size());

  grpc::ClientContext complete_ctx;
  v1::CompleteJobRequest complete;
  complete.set_job_id(leased.job().job_id());
  complete.set_lease_id(leased.job().lease_id());
  *complete.mutable_result() = manifest;
  v1::CompleteJobResponse completed;
  s = server.workers().CompleteJob(&complete_ctx, complete, &completed);
  EXPECT_TRUE(s.ok()) << s.error_message();
  return out;
}

PublishedResult PublishResult(ServerProcess& server, const std::vector<int64_t>& map_sizes, uint32_t seed,
                              bool one_blob, uint32_t map_seed) {
  // A unique model: its bytes enter the cache key. The server never parses
  // it (no worker will), so any bytes with a .glb name do.
  const std::string model = "glTF" + RandomBytes(64, seed);
  v1::SubmitBakeRequest submit;
  submit.mutable_mesh()->mutable_entry()->set_path("model.glb");
  *submit.mutable_mesh()->mutable_entry()->mutable_digest() = DigestOf(model);
  EXPECT_TRUE(UploadBytes(server.assets(), model, submit.mesh().entry().digest()).ok());
  submit.mutable_parameters()->set_frames(3);
  submit.mutable_parameters()->set_resolution(64);
  grpc::ClientContext ctx;
  v1::SubmitBakeResponse submitted;
  const grpc::Status s = server.bake().SubmitBake(&ctx, submit, &submitted);
  EXPECT_TRUE(s.ok()) << s.error_message();
  PublishedResult out = CompleteNextJob(server, map_sizes, seed, one_blob, map_seed);
  EXPECT_EQ(out.key, submitted.cache_key());
  return out;
}

}  // namespace impostor::testing
