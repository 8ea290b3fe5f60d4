// The client SDK and the `impostor` CLI against a real server and worker:
// a .gltf with external buffers and textures, uploads of only what is
// missing, fetch with verification, cache hits, and the CLI's exit codes.
#include <filesystem>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

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

const fs::path kTree = "vegetation/TreeLowPoly_RicardoSanchez/scene_alphaMASK.gltf";

TEST(SdkEndToEnd, BakesAGltfWithExternalFilesAndFetchesItVerified) {
  ServerProcess server(/*local_workers=*/1);
  auto client = sdk::Client::Connect({.server = server.address()});
  ASSERT_TRUE(client.ok()) << client.status();
  const sdk::BakeSettings settings{.layout = "hemi-octahedral", .frames = 4, .resolution = 256};

  auto submitted = (*client)->SubmitBake(AssetsDir() / kTree, settings);
  ASSERT_TRUE(submitted.ok()) << submitted.status();
  EXPECT_EQ(submitted->upload.files, 4) << "the .gltf, its .bin and two textures";
  EXPECT_EQ(submitted->upload.uploaded, 4);
  auto done = testing::WatchJobWithin(**client, submitted->job_id, [&] { server.Kill(); });
  ASSERT_TRUE(done.ok()) << done.status();
  ASSERT_EQ(done->state, sdk::JobState::kSucceeded) << done->error_message;

  const fs::path out = testing::NewTempDir("sdk_fetch");
  auto fetched = (*client)->Fetch(submitted->cache_key, out);
  ASSERT_TRUE(fetched.ok()) << fetched.status();
  auto manifest = ManifestFromJson(testing::ReadFileBytes(fetched->manifest_path));
  ASSERT_TRUE(manifest.ok()) << manifest.status();
  EXPECT_EQ(manifest->layout(), v1::LAYOUT_HEMI_OCTAHEDRAL);
  EXPECT_EQ(manifest->views_size(), 16);
  EXPECT_EQ(manifest->mesh().triangles(), 778u);
  for (const auto& map : manifest->maps()) {
    auto digest = DigestFile(out / map.file());
    ASSERT_TRUE(digest.ok()) << map.file();
    EXPECT_EQ(digest->hash, map.digest().hash()) << map.file();
  }

  // Second time: nothing to upload, answered from the cache, and a fetch into
  // the same directory reuses the intact files.
  auto again = (*client)->SubmitBake(AssetsDir() / kTree, settings);
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_TRUE(again->cached);
  EXPECT_EQ(again->upload.uploaded, 0);
  EXPECT_EQ(again->cache_key, submitted->cache_key);
  auto refetched = (*client)->Fetch(again->cache_key, out);
  ASSERT_TRUE(refetched.ok()) << refetched.status();
  EXPECT_EQ(refetched->bytes_downloaded, 0);
  EXPECT_GT(refetched->bytes_reused, 0);
}

// The --json line of `impostor bake` (the last line starting with '{').
nlohmann::json BakeJson(const std::string& stdout_text) {
  const size_t at = stdout_text.rfind("\n{", stdout_text.size() - 2);
  const std::string line = stdout_text.substr(at == std::string::npos ? 0 : at + 1);
  return nlohmann::json::parse(line, nullptr, /*allow_exceptions=*/false);
}

struct CliCase {
  const char* name;
  std::vector<std::string> args;  // after "impostor", --server added
  int exit_code;
  // For exit 0: the --json line's "cached". Otherwise: what the one
  // "impostor: ..." line on stderr must say.
  bool cached;
  const char* stderr_mentions;
};

TEST(CliEndToEnd, ExitCodesSayWhatHappened) {
  ServerProcess server(/*local_workers=*/1);
  const fs::path out = testing::NewTempDir("cli_out");
  const std::string box = (AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb").string();
  const CliCase cases[] = {
      {"bake succeeds", {"bake", box, "--frames", "3", "--resolution", "64", "--out", out.string(), "--json"}, 0,
       false, ""},
      {"bake again is cached", {"bake", box, "--frames", "3", "--resolution", "64", "--out", out.string(), "--json"},
       0, true, ""},
      {"out-of-range frames", {"bake", box, "--frames", "80", "--out", out.string()}, 1, false,
       "impostor: bake failed: INVALID_ARGUMENT: --frames (parameters.frames): 80 is out of range"},
      {"missing model", {"bake", "/nonexistent/model.glb", "--out", out.string()}, 4, false, "/nonexistent/model.glb"},
      {"unknown flag", {"bake", box, "--out", out.string(), "--colour", "red"}, 2, false, "colour"},
      {"unreachable server", {"status", "job-x", "--server", "127.0.0.1:1"}, 3, false, "127.0.0.1:1"},
  };
  for (const CliCase& c : cases) {
    std::vector<std::string> argv = {(testing::BinaryDir() / "impostor").string()};
    argv.insert(argv.end(), c.args.begin(), c.args.end());
    if (std::find(argv.begin(), argv.end(), "--server") == argv.end()) {
      argv.push_back("--server");
      argv.push_back(server.address());
    }
    const testing::ToolRun run = testing::RunTool(argv);
    EXPECT_EQ(run.exit_code, c.exit_code) << c.name << "\nstdout: " << run.out << "\nstderr: " << run.err;
    if (c.exit_code == 0) {
      const nlohmann::json line = BakeJson(run.out);
      ASSERT_TRUE(line.is_object()) << c.name << ": no JSON line in " << run.out;
      EXPECT_EQ(line.value("cached", !c.cached), c.cached) << c.name << ": " << line.dump();
      EXPECT_EQ(line.value("cache_key", std::string()).size(), 64u) << c.name << ": " << line.dump();
    } else {
      EXPECT_NE(run.err.find(c.stderr_mentions), std::string::npos) << c.name << ": stderr: " << run.err;
    }
  }
  EXPECT_TRUE(fs::exists(out / "albedo_alpha.png"));
  EXPECT_TRUE(fs::exists(out / "manifest.json"));
}

}  // namespace
}  // namespace impostor
