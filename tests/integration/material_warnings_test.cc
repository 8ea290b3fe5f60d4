// What the baker works around or cannot bake reaches the user: loader
// warnings travel through the manifest to the SDK and the CLI, a missing
// texture file is a clear error naming it, and the optional emissive map is
// baked, listed and fetched when asked for.
#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/manifest/manifest_json.h"
#include "common/util/sha256.h"
#include "impostor/client.h"
#include "tests/integration/sdk_watch.h"
#include "tests/support/server_process.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::AssetsDir;
using testing::ServerProcess;

const fs::path kPrimitiveModes = "edge_cases/khronos/MeshPrimitiveModes/glTF/MeshPrimitiveModes.gltf";

bool Mentions(const std::vector<std::string>& lines, const std::string& needle) {
  return std::any_of(lines.begin(), lines.end(),
                     [&](const std::string& l) { return l.find(needle) != std::string::npos; });
}

TEST(MaterialWarningsEndToEnd, WarningsTravelToTheSdkAndTheCli) {
  if (!fs::exists(AssetsDir() / kPrimitiveModes)) GTEST_SKIP() << "asset missing";
  ServerProcess server(/*local_workers=*/1);
  auto client = sdk::Client::Connect({.server = server.address()});
  ASSERT_TRUE(client.ok()) << client.status();
  const sdk::BakeSettings settings{.frames = 3, .resolution = 64};
  auto submitted = (*client)->SubmitBake(AssetsDir() / kPrimitiveModes, settings);
  ASSERT_TRUE(submitted.ok()) << submitted.status();
  auto done = testing::WatchJobWithin(**client, submitted->job_id, [&] { server.Kill(); });
  ASSERT_TRUE(done.ok()) << done.status();
  ASSERT_EQ(done->state, sdk::JobState::kSucceeded) << done->error_message;
  const fs::path out = testing::NewTempDir("warnings_fetch");
  auto fetched = (*client)->Fetch(submitted->cache_key, out);
  ASSERT_TRUE(fetched.ok()) << fetched.status();
  EXPECT_TRUE(Mentions(fetched->warnings, "points/lines primitives skipped"));
  auto manifest = ManifestFromJson(testing::ReadFileBytes(fetched->manifest_path));
  ASSERT_TRUE(manifest.ok()) << manifest.status();
  ASSERT_EQ(manifest->warnings_size(), static_cast<int>(fetched->warnings.size()));
  EXPECT_NE(manifest->warnings(0).find("mesh with POINTS"), std::string::npos)
      << manifest->warnings(0);

  // The CLI prints them (stderr as text, stdout in --json).
  const fs::path cli_out = testing::NewTempDir("warnings_cli");
  testing::ChildProcess cli({(testing::BinaryDir() / "impostor").string(), "bake",
                             (AssetsDir() / kPrimitiveModes).string(), "--frames", "3",
                             "--resolution", "64", "--out", cli_out.string(), "--json", "--server",
                             server.address()});
  std::string stdout_text;
  EXPECT_EQ(cli.Wait(&stdout_text), 0);
  EXPECT_NE(stdout_text.find("\"warnings\":[\"points/lines primitives skipped"),
            std::string::npos)
      << stdout_text;

  // Also when the quality gate rejects the result (it is downloaded for
  // inspection, warnings and all), and for each model of a batch.
  const fs::path gated_out = testing::NewTempDir("warnings_gated");
  testing::ChildProcess gated({(testing::BinaryDir() / "impostor").string(), "bake",
                               (AssetsDir() / kPrimitiveModes).string(), "--frames", "3", "--resolution", "64",
                               "--min-iou", "1", "--out", gated_out.string(), "--json", "--server", server.address()});
  stdout_text.clear();
  EXPECT_EQ(gated.Wait(&stdout_text), 1) << "the gate of IoU 1 fails";
  EXPECT_NE(stdout_text.find("\"warnings\":[\"points/lines primitives skipped"), std::string::npos)
      << stdout_text;
  EXPECT_NE(gated.Stderr().find("warning: points/lines primitives skipped"), std::string::npos) << gated.Stderr();

  const fs::path batch_out = testing::NewTempDir("warnings_batch");
  testing::ChildProcess batch({(testing::BinaryDir() / "impostor").string(), "bake",
                               (AssetsDir() / kPrimitiveModes).string(),
                               (AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb").string(), "--frames", "3",
                               "--resolution", "64", "--out", batch_out.string(), "--json", "--server",
                               server.address()});
  stdout_text.clear();
  EXPECT_EQ(batch.Wait(&stdout_text), 0) << batch.Stderr();
  EXPECT_NE(stdout_text.find("\"warnings\":[\"points/lines primitives skipped"), std::string::npos)
      << stdout_text;
  EXPECT_NE(stdout_text.find("\"warnings\":[]"), std::string::npos) << "Box has none: " << stdout_text;
  EXPECT_NE(batch.Stderr().find("warning: MeshPrimitiveModes: points/lines primitives skipped"), std::string::npos)
      << batch.Stderr();
}

TEST(MaterialWarningsEndToEnd, MissingTextureFileFailsTheBakeNamingTheFile) {
  const fs::path model = "edge_cases/missing_textures/BoxTextured_png_removed/BoxTextured.gltf";
  if (!fs::exists(AssetsDir() / model)) GTEST_SKIP() << "asset missing";
  ServerProcess server(/*local_workers=*/1);
  auto client = sdk::Client::Connect({.server = server.address()});
  ASSERT_TRUE(client.ok()) << client.status();
  auto submitted =
      (*client)->SubmitBake(AssetsDir() / model, sdk::BakeSettings{.frames = 3, .resolution = 64});
  std::string message;
  if (!submitted.ok()) {
    message = std::string(submitted.status().message());  // refused before upload
  } else {
    auto done = testing::WatchJobWithin(**client, submitted->job_id, [&] { server.Kill(); });
    ASSERT_TRUE(done.ok()) << done.status();
    EXPECT_EQ(done->state, sdk::JobState::kFailed);
    message = done->error_message;
  }
  EXPECT_NE(message.find("CesiumLogoFlat.png"), std::string::npos) << message;
}

TEST(MaterialWarningsEndToEnd, EmissiveMapIsBakedListedAndFetched) {
  const fs::path model = "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb";
  if (!fs::exists(AssetsDir() / model)) GTEST_SKIP() << "asset missing";
  ServerProcess server(/*local_workers=*/1);
  auto client = sdk::Client::Connect({.server = server.address()});
  ASSERT_TRUE(client.ok()) << client.status();
  sdk::BakeSettings settings{.frames = 3, .resolution = 64};
  settings.emissive = true;
  auto submitted = (*client)->SubmitBake(AssetsDir() / model, settings);
  ASSERT_TRUE(submitted.ok()) << submitted.status();
  auto done = testing::WatchJobWithin(**client, submitted->job_id, [&] { server.Kill(); });
  ASSERT_TRUE(done.ok()) << done.status();
  ASSERT_EQ(done->state, sdk::JobState::kSucceeded) << done->error_message;
  const fs::path out = testing::NewTempDir("emissive_fetch");
  auto fetched = (*client)->Fetch(submitted->cache_key, out);
  ASSERT_TRUE(fetched.ok()) << fetched.status();
  auto manifest = ManifestFromJson(testing::ReadFileBytes(fetched->manifest_path));
  ASSERT_TRUE(manifest.ok()) << manifest.status();
  bool listed = false;
  for (const auto& map : manifest->maps()) {
    if (map.semantic() != "emissive") continue;
    listed = true;
    EXPECT_EQ(map.file(), "emissive.png");
    auto digest = DigestFile(out / map.file());
    ASSERT_TRUE(digest.ok());
    EXPECT_EQ(digest->hash, map.digest().hash());
  }
  EXPECT_TRUE(listed);
  // Without the flag: another cache key and no emissive map.
  auto plain = (*client)->SubmitBake(AssetsDir() / model,
                                     sdk::BakeSettings{.frames = 3, .resolution = 64});
  ASSERT_TRUE(plain.ok()) << plain.status();
  EXPECT_NE(plain->cache_key, submitted->cache_key);
}

}  // namespace
}  // namespace impostor
