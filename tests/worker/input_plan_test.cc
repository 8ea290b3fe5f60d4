// A job's inputs grouped by blob (worker/input_plan.h): one download per
// distinct digest whatever the number of paths, and what the plan takes on
// disk, folders and hostile sizes included.
#include "worker/input_plan.h"

#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

const fs::path kInput = "/scratch/job-0/input";

v1::Digest Digest(char fill, int64_t size) {
  v1::Digest d;
  d.set_hash(std::string(64, fill));
  d.set_size_bytes(size);
  return d;
}

struct File {
  std::string path;
  v1::Digest digest;
};

v1::MeshInput Mesh(const File& entry, const std::vector<File>& files) {
  v1::MeshInput mesh;
  mesh.mutable_entry()->set_path(entry.path);
  *mesh.mutable_entry()->mutable_digest() = entry.digest;
  for (const File& f : files) {
    v1::InputFile* added = mesh.add_files();
    added->set_path(f.path);
    *added->mutable_digest() = f.digest;
  }
  return mesh;
}

TEST(InputPlan, OneBlobUnder4096PathsIsOneDownload) {
  std::vector<File> files;
  for (int i = 0; i < 4096; ++i) files.push_back({absl::StrCat("tex/t", i, ".png"), Digest('b', 1 << 20)});
  const InputPlan plan = PlanInputs(Mesh({"m.gltf", Digest('a', 100)}, files), kInput);
  ASSERT_EQ(plan.blobs.size(), 2u);
  EXPECT_EQ(plan.path_count, 4097);
  EXPECT_EQ(plan.blobs[0].paths, std::vector<fs::path>{kInput / "m.gltf"});
  ASSERT_EQ(plan.blobs[1].paths.size(), 4096u);
  EXPECT_EQ(plan.blobs[1].paths.front(), kInput / "tex/t0.png");
  EXPECT_EQ(plan.blobs[1].paths.back(), kInput / "tex/t4095.png");
  // One MiB once, not 4 GiB: the blob, the entry and two folders.
  const ScratchDemand demand = EstimateScratchDemand(plan, kInput, 4096);
  EXPECT_EQ(demand.blob_count, 2);
  EXPECT_EQ(demand.path_count, 4097);
  EXPECT_LT(demand.bytes, (1 << 20) + 4096 + (4096 * 24));
  EXPECT_EQ(demand.inodes, 2 + 2);
}

TEST(InputPlan, BlobsAreTheSameOnlyWhenHashAndSizeBothMatch) {
  struct Case {
    const char* name;
    v1::Digest entry, a, b;
    size_t blobs;
  };
  const Case cases[] = {
      {"all distinct", Digest('e', 10), Digest('a', 10), Digest('b', 10), 3},
      {"files share", Digest('e', 10), Digest('a', 10), Digest('a', 10), 2},
      {"a file shares the entry's", Digest('e', 10), Digest('e', 10), Digest('b', 10), 2},
      {"same hash, other size", Digest('e', 10), Digest('a', 10), Digest('a', 11), 3},
      {"all one", Digest('e', 0), Digest('e', 0), Digest('e', 0), 1},
  };
  for (const Case& c : cases) {
    const InputPlan plan = PlanInputs(Mesh({"dir/m.glb", c.entry}, {{"a.bin", c.a}, {"b.bin", c.b}}), kInput);
    EXPECT_EQ(plan.blobs.size(), c.blobs) << c.name;
    // The entry is always written, never a link: its name is its file name.
    EXPECT_EQ(plan.entry_path, kInput / "m.glb") << c.name;
    EXPECT_EQ(plan.blobs[0].paths.front(), kInput / "m.glb") << c.name;
    size_t paths = 0;
    for (const InputBlob& blob : plan.blobs) paths += blob.paths.size();
    EXPECT_EQ(paths, 3u) << c.name;
  }
}

TEST(InputPlan, DemandRoundsBlobsAndFoldersToWholeBlocks) {
  struct Case {
    const char* name;
    std::vector<File> files;
    int64_t bytes;   // with 4096-byte blocks; entry "m.glb" of 1 byte
    int64_t inodes;
  };
  const Case cases[] = {
      {"the entry alone", {}, 4096 + 4096, 2},
      {"an empty blob takes no block", {{"e.bin", Digest('z', 0)}}, 4096 + 4096, 3},
      {"one byte over a block", {{"a.bin", Digest('a', 4097)}}, 4096 + 8192 + 4096, 3},
      {"a folder is a block", {{"d/a.bin", Digest('a', 10)}}, 4096 + 4096 + 2 * 4096, 4},
      {"a folder counts once", {{"d/a.bin", Digest('a', 10)}, {"d/b.bin", Digest('b', 10)}},
       3 * 4096 + 2 * 4096, 5},
      {"nested folders each count", {{"d/e/f/a.bin", Digest('a', 10)}}, 2 * 4096 + 4 * 4096, 6},
      {"a link takes no data block", {{"a.bin", Digest('a', 10)}, {"b.bin", Digest('a', 10)}}, 3 * 4096, 3},
  };
  for (const Case& c : cases) {
    const ScratchDemand demand =
        EstimateScratchDemand(PlanInputs(Mesh({"m.glb", Digest('m', 1)}, c.files), kInput), kInput, 4096);
    EXPECT_EQ(demand.bytes, c.bytes) << c.name;
    EXPECT_EQ(demand.inodes, c.inodes) << c.name;
  }
}

// Hostile shapes of the request: the estimate must see them, not overflow.
TEST(InputPlan, DemandSeesDeepFoldersLongNamesAndHugeSizes) {
  // 4096 paths, each under its own chain of 500 one-letter folders: two
  // million folders, 8 GB of directory blocks on ext4 for a tiny upload.
  std::vector<File> deep;
  std::string chain;
  for (int i = 0; i < 500; ++i) chain += "a/";
  for (int i = 0; i < 4096; ++i) deep.push_back({absl::StrCat(i, "/", chain, "f"), Digest('d', 1)});
  const ScratchDemand deep_demand =
      EstimateScratchDemand(PlanInputs(Mesh({"m.glb", Digest('m', 1)}, deep), kInput), kInput, 4096);
  EXPECT_EQ(deep_demand.inodes, 2 + 1 + 4096 * 501) << "blobs, input folder, folders";
  EXPECT_GE(deep_demand.bytes, int64_t{4096} * 501 * 4096);

  // 4096 links with 1000-byte names in one folder: 4 MB of directory
  // entries although the data is one block.
  std::vector<File> wide;
  for (int i = 0; i < 4096; ++i) wide.push_back({absl::StrCat(i, std::string(996, 'n')), Digest('w', 1)});
  const ScratchDemand wide_demand =
      EstimateScratchDemand(PlanInputs(Mesh({"m.glb", Digest('m', 1)}, wide), kInput), kInput, 4096);
  EXPECT_GE(wide_demand.bytes, int64_t{4096} * 1000);
  EXPECT_EQ(wide_demand.inodes, 3);

  // Sizes near INT64_MAX saturate instead of wrapping to a small number.
  const int64_t max = std::numeric_limits<int64_t>::max();
  const ScratchDemand huge = EstimateScratchDemand(
      PlanInputs(Mesh({"m.glb", Digest('m', max)}, {{"a", Digest('a', max)}, {"b", Digest('b', max - 1)}}), kInput),
      kInput, 4096);
  EXPECT_EQ(huge.bytes, max);
}

}  // namespace
}  // namespace impostor
