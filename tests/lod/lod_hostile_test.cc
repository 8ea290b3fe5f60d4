// The LOD writer and attributes it does not know (issue 23): it used to read
// every attribute of a primitive with a count bound of 2^32
// (lod_glb_writer.cc:163 at commit 449b765), so an extra attribute declaring
// 60,000,000 elements without a bufferView allocated 720 MB of zeros before
// the count was compared with POSITION's. Now the count is compared first
// and such an attribute is dropped unread.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

#include "worker/lod/lod_glb_writer.h"
#include "worker/lod/lod_source.h"
#include "tests/hostile/peak_rss.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

TEST(LodHostile, AnOversizedExtraAttributeIsDroppedUnread) {
  const fs::path dir = fs::temp_directory_path() / ("impostor_lod_hostile_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path model = dir / "m.gltf";
  // One triangle (positions and ushort indices in one embedded buffer) and
  // an attribute _JUNK of 60,000,000 VEC4 with no bufferView.
  std::ofstream(model) << R"({"asset":{"version":"2.0"},
    "buffers":[{"byteLength":44,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAABAAIAAAA="}],
    "bufferViews":[{"buffer":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":6}],
    "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
                 {"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"},
                 {"componentType":5126,"count":60000000,"type":"VEC4"}],
    "meshes":[{"primitives":[{"attributes":{"POSITION":0,"_JUNK":2},"indices":1}]}],
    "nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}],"scene":0})";
  std::ofstream("/proc/self/clear_refs") << "5";
  const absl::StatusOr<LodSource> source = LoadLodSource(model, {});
  ASSERT_TRUE(source.ok()) << source.status();
  ASSERT_EQ(source->primitives.size(), 1u);
  const absl::StatusOr<std::string> glb =
      EncodeLodGlb(*source, {{0, 1, 2}}, LodTextureFileNames(source->model));
  ASSERT_TRUE(glb.ok()) << glb.status();
  EXPECT_EQ(glb->find("_JUNK"), std::string::npos) << "the oversized attribute was written";
  EXPECT_NE(glb->find("POSITION"), std::string::npos);
  EXPECT_LT(testing::PeakRss(), uint64_t{512} << 20);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace impostor
