// Surfel products through the whole service: a real impostor-server with a
// real impostor-worker on loopback, a foliage asset (alpha-masked leaf
// cards) baked with the vegetation preset via the SDK, the fetched buffer
// used as-is, and the CLI's surfel flags and refusals.
#include <cstring>
#include <filesystem>
#include <fstream>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "common/manifest/manifest_json.h"
#include "common/util/sha256.h"
#include "impostor/client.h"
#include "tests/integration/sdk_watch.h"
#include "tests/support/server_process.h"
#include "tests/surfels/mesh_distance.h"
#include "worker/scene/gltf_loader.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::AssetsDir;
using testing::ServerProcess;

const fs::path kTree = "vegetation/TreeLowPoly_RicardoSanchez/scene_alphaMASK.gltf";

TEST(SurfelService, BakesAFoliageAssetWithTheVegetationPresetAndFetchesTheCloud) {
  ServerProcess server(/*local_workers=*/1);
  auto client = sdk::Client::Connect({.server = server.address()});
  ASSERT_TRUE(client.ok()) << client.status();
  sdk::BakeSettings settings;
  settings.product = "surfels";
  settings.preset = "vegetation";

  const auto start = std::chrono::steady_clock::now();
  auto submitted = (*client)->SubmitBake(AssetsDir() / kTree, settings);
  ASSERT_TRUE(submitted.ok()) << submitted.status();
  auto done = testing::WatchJobWithin(**client, submitted->job_id, [&] { server.Kill(); });
  ASSERT_TRUE(done.ok()) << done.status();
  ASSERT_EQ(done->state, sdk::JobState::kSucceeded) << done->error_message;
  const double bake_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  const fs::path out = testing::NewTempDir("surfel_fetch");
  auto fetched = (*client)->Fetch(submitted->cache_key, out);
  ASSERT_TRUE(fetched.ok()) << fetched.status();
  EXPECT_EQ(fetched->files.size(), 3u) << "surfels.bin, surfels.ply, manifest.json";
  auto manifest = ManifestFromJson(testing::ReadFileBytes(fetched->manifest_path));
  ASSERT_TRUE(manifest.ok()) << manifest.status();
  ASSERT_EQ(manifest->product(), v1::PRODUCT_SURFELS);
  const v1::SurfelCloud& s = manifest->surfels();
  EXPECT_EQ(s.point_budget(), 32768u);
  EXPECT_EQ(s.capture_frames(), 24u);
  EXPECT_EQ(s.capture_resolution(), 2048u);
  EXPECT_LE(s.point_count(), 32768u);
  EXPECT_GE(s.point_count(), 0.9 * 32768) << "a tree has enough surface";
  EXPECT_NEAR(s.point_diameter(), s.voxel_size() * std::sqrt(2.0f), 1e-6f);
  EXPECT_GT(s.quality().silhouette_iou_mean(), 0.6f);

  // The buffer as a game gets it: the file's bytes are the instance buffer.
  const std::string bytes = testing::ReadFileBytes(out / s.file());
  EXPECT_EQ(Sha256Hex(bytes), s.digest().hash());
  ASSERT_EQ(bytes.size(), size_t{48} * s.point_count());
  std::vector<float> f(bytes.size() / 4);
  std::memcpy(f.data(), bytes.data(), bytes.size());  // little-endian host

  auto scene = LoadGltfScene(AssetsDir() / kTree);
  ASSERT_TRUE(scene.ok()) << scene.status();
  const glm::vec3 center(manifest->bounding_sphere().center(0), manifest->bounding_sphere().center(1),
                         manifest->bounding_sphere().center(2));
  const float radius = manifest->bounding_sphere().radius();
  float worst_surface = 0;
  for (size_t i = 0; i < s.point_count(); ++i) {
    const float* p = &f[i * 12];
    const glm::vec3 position(p[0], p[1], p[2]), normal(p[3], p[4], p[5]);
    ASSERT_NEAR(glm::length(normal), 1.0f, 1e-4f) << "point " << i;
    ASSERT_LE(glm::length(position - center), radius * (1 + 1e-4f)) << "point " << i;
    for (int c = 6; c < 12; ++c) ASSERT_TRUE(p[c] >= 0.0f && p[c] <= 1.0f) << "point " << i << " float " << c;
    worst_surface = std::max(worst_surface, testing::DistanceToMesh(*scene, position));
  }
  EXPECT_LE(worst_surface, s.voxel_size()) << "every point within one voxel of the triangles";
  std::printf("[ figures  ] tree: %u / %u points (fill %.4f), voxel %.5f, diameter %.5f, samples %llu, "
              "iou mean %.4f min %.4f (%u px), albedo PSNR %.2f dB, worst distance %.2f voxel, submit-to-done %.2f s\n",
              s.point_count(), s.point_budget(), s.budget_fill(), s.voxel_size(), s.point_diameter(),
              static_cast<unsigned long long>(s.sample_count()), s.quality().silhouette_iou_mean(),
              s.quality().silhouette_iou_min(), s.quality().view_pixels(), s.quality().albedo_psnr_db(),
              worst_surface / s.voxel_size(), bake_seconds);

  // The same request again is a cache hit; an atlas of the same mesh is not.
  auto again = (*client)->SubmitBake(AssetsDir() / kTree, settings);
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_TRUE(again->cached);
  EXPECT_EQ(again->cache_key, submitted->cache_key);
}

struct CliCase {
  const char* name;
  std::vector<std::string> args;  // after "impostor"; --server and --json added
  int exit_code;
  const char* stdout_mentions;
};

TEST(SurfelService, CliBakesSurfelsAndRefusesBadParametersClearly) {
  ServerProcess server(/*local_workers=*/1);
  const fs::path out = testing::NewTempDir("surfel_cli");
  const std::string box = (AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb").string();
  const CliCase cases[] = {
      {"prop preset, small budget",
       {"bake", box, "--product", "surfels", "--preset", "prop", "--point-budget", "300", "--out", out.string()},
       0, "surfels.bin"},
      {"zero budget", {"bake", box, "--product", "surfels", "--point-budget", "0", "--out", out.string()}, 1,
       "--point-budget (parameters.point_budget): 0 is out of range 1..4194304"},
      {"absurd budget", {"bake", box, "--product", "surfels", "--point-budget", "99999999", "--out", out.string()},
       1, "--point-budget (parameters.point_budget): 99999999 is out of range 1..4194304"},
      {"frames out of range", {"bake", box, "--product", "surfels", "--frames", "65", "--out", out.string()}, 1,
       "--frames (parameters.frames): 65 is out of range 2..64"},
      {"unknown preset", {"bake", box, "--product", "surfels", "--preset", "forest", "--out", out.string()}, 1,
       "unknown preset \\\"forest\\\""},
      {"budget on an atlas", {"bake", box, "--point-budget", "100", "--out", out.string()}, 1,
       "only for product surfels"},
      {"unknown product", {"bake", box, "--product", "voxels", "--out", out.string()}, 2,
       "impostor: --product: unknown product \"voxels\""},
  };
  for (const CliCase& c : cases) {
    std::vector<std::string> argv = {(testing::BinaryDir() / "impostor").string()};
    argv.insert(argv.end(), c.args.begin(), c.args.end());
    for (const char* a : {"--server", server.address().c_str(), "--json"}) argv.push_back(a);
    // The reason of a failure is on stdout (--json) or on stderr (usage).
    const testing::ToolRun run = testing::RunTool(argv);
    EXPECT_EQ(run.exit_code, c.exit_code) << c.name << ": " << run.out << run.err;
    EXPECT_NE((run.out + run.err).find(c.stdout_mentions), std::string::npos) << c.name << ": " << run.out << run.err;
  }
  auto manifest = ManifestFromJson(testing::ReadFileBytes(out / "manifest.json"));
  ASSERT_TRUE(manifest.ok()) << manifest.status();
  EXPECT_EQ(manifest->surfels().point_budget(), 300u);
  EXPECT_LE(manifest->surfels().point_count(), 300u);
  EXPECT_TRUE(fs::exists(out / "surfels.ply"));
}

}  // namespace
}  // namespace impostor
