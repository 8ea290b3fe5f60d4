// CheckLoadInChild (worker/scene/isolated_load.h): the load in a child
// process under rlimits reports what the in-process load would, a bomb that
// slips past the load budget ends the child and not this process, and a
// cancelled load ends at once.
#include "worker/scene/isolated_load.h"

#include <gtest/gtest.h>

#include <fstream>
#include <limits>
#include <string>

#include "tests/hostile/hostile_cases.h"
#include "tests/scene/test_assets.h"
#include "tests/hostile/peak_rss.h"
#include "worker/scene/scene_wire.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

TEST(IsolatedLoadTest, RealAssetLoadsInTheChild) {
  const fs::path path = testing::Asset("props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb");
  if (!fs::exists(path)) GTEST_SKIP() << "no assets";
  EXPECT_TRUE(CheckLoadInChild(path, {}, {}).ok());
}

TEST(IsolatedLoadTest, ChildReportsWhatTheLoaderSays) {
  for (const testing::HostileCase& c : testing::kHostileCases) {
    const absl::Status s = CheckLoadInChild(testing::HostileCorpusDir() / c.file, {}, {});
    EXPECT_EQ(static_cast<int>(s.code()), c.code) << c.file << ": " << s;
    EXPECT_NE(s.message().find(c.needle), std::string::npos) << c.file << ": " << s;
  }
}

// With the budget opened wide, the issue 23 reproduction reaches the
// builder, which allocates 720 MB for the instance translations: the child's
// address-space limit stops it, and this process never holds that memory.
TEST(IsolatedLoadTest, BombPastTheBudgetEndsTheChildOnly) {
  std::ofstream("/proc/self/clear_refs") << "5";
  GltfLoadLimits lax;
  lax.max_triangles = 700'000'000;
  lax.max_draws = uint64_t{1} << 31;
  lax.max_load_bytes = std::numeric_limits<uint64_t>::max();
  LoadIsolation isolation;
  isolation.address_space_bytes = uint64_t{256} << 20;
  const absl::Status s = CheckLoadInChild(
      testing::HostileCorpusDir() / "instancing_60m_no_bufferview.gltf", lax, isolation);
  EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted) << s;
  EXPECT_NE(s.message().find("LoadIsolation::address_space_bytes"), std::string::npos) << s;
  EXPECT_LT(testing::PeakRss(), testing::kPeakRssBound);
}

TEST(IsolatedLoadTest, CancelledLoadEnds) {
  const std::atomic<bool> cancelled{true};
  const absl::Status s =
      CheckLoadInChild(testing::HostileCorpusDir() / "morph_1000_targets_x_100k.gltf", {}, {}, &cancelled);
  EXPECT_EQ(s.code(), absl::StatusCode::kCancelled) << s;
}

TEST(IsolatedLoadTest, DisabledDoesNothingAndBadSettingsAreNamed) {
  EXPECT_TRUE(CheckLoadInChild("/nonexistent.gltf", {}, {.enabled = false}).ok());
  const absl::Status s = CheckLoadInChild("/nonexistent.gltf", {}, {.cpu_seconds = 0});
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << s;
  EXPECT_NE(s.message().find("cpu_seconds 0"), std::string::npos) << s;
  // A missing file is the loader's NOT_FOUND, carried back from the child.
  EXPECT_EQ(CheckLoadInChild("/nonexistent.gltf", {}, {}).code(), absl::StatusCode::kNotFound);
}


// LoadSceneInChild hands back exactly the scene an in-process load builds
// (compared as the wire bytes, which have no padding), with isolation on
// and off.
TEST(IsolatedLoadTest, TheChildsSceneIsTheInProcessScene) {
  const fs::path path = testing::Asset("props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb");
  if (!fs::exists(path)) GTEST_SKIP() << "no assets";
  const absl::StatusOr<Scene> here = LoadGltfScene(path, {});
  ASSERT_TRUE(here.ok()) << here.status();
  std::string expected;
  EncodeScene(*here, &expected);
  for (bool enabled : {true, false}) {
    LoadIsolation isolation;
    isolation.enabled = enabled;
    const absl::StatusOr<Scene> scene = LoadSceneInChild(path, {}, isolation);
    ASSERT_TRUE(scene.ok()) << scene.status();
    std::string got;
    EncodeScene(*scene, &got);
    EXPECT_TRUE(got == expected) << "isolation " << enabled << ": " << got.size() << " vs " << expected.size()
                                 << " bytes";
  }
}

TEST(IsolatedLoadTest, LoadSceneInChildReportsWhatTheCheckReports) {
  for (const testing::HostileCase& c : testing::kHostileCases) {
    const absl::StatusOr<Scene> s = LoadSceneInChild(testing::HostileCorpusDir() / c.file, {}, {});
    EXPECT_EQ(static_cast<int>(s.status().code()), c.code) << c.file << ": " << s.status();
  }
  LoadIsolation isolation;
  isolation.address_space_bytes = uint64_t{256} << 20;
  GltfLoadLimits lax;
  lax.max_triangles = 700'000'000;
  lax.max_draws = uint64_t{1} << 31;
  lax.max_load_bytes = std::numeric_limits<uint64_t>::max();
  const absl::StatusOr<Scene> bomb =
      LoadSceneInChild(testing::HostileCorpusDir() / "instancing_60m_no_bufferview.gltf", lax, isolation);
  EXPECT_EQ(bomb.status().code(), absl::StatusCode::kResourceExhausted) << bomb.status();
}

}  // namespace
}  // namespace impostor
