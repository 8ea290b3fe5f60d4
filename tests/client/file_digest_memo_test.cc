// A batch hashes each local file once while it is unchanged
// (client/transfer/file_digest_memo.h): the same path again costs no
// hashing; a file rewritten with other bytes (or replaced by another file
// under its name) is hashed again and gets its new digest; a missing file
// is an error naming it; and a batch of several models sharing files
// (HashMesh with one memo) hashes each of them once, with the digests a
// memo-less HashMesh gives.
#include "client/transfer/file_digest_memo.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "client/transfer/mesh_files.h"
#include "client/transfer/mesh_upload.h"
#include "common/util/sha256.h"

namespace impostor::sdk {
namespace {

namespace fs = std::filesystem;

class FileDigestMemoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("impostor_digest_memo_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path Write(const std::string& name, const std::string& bytes) {
    const fs::path path = dir_ / name;
    std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
    return path;
  }

  fs::path dir_;
};

TEST_F(FileDigestMemoTest, AnUnchangedFileIsHashedOnce) {
  const fs::path a = Write("a.bin", std::string(100'000, 'a'));
  FileDigestMemo memo;
  absl::StatusOr<v1::Digest> first = memo.Get(a);
  ASSERT_TRUE(first.ok()) << first.status();
  EXPECT_EQ(first->hash(), Sha256Hex(std::string(100'000, 'a')));
  EXPECT_EQ(first->size_bytes(), 100'000);
  absl::StatusOr<v1::Digest> again = memo.Get(a);
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_EQ(again->hash(), first->hash());
  EXPECT_EQ(memo.bytes_hashed(), 100'000) << "hashed twice";
}

TEST_F(FileDigestMemoTest, AChangedOrReplacedFileIsHashedAgain) {
  const fs::path a = Write("a.bin", "first bytes");
  FileDigestMemo memo;
  ASSERT_TRUE(memo.Get(a).ok());
  // Other bytes of another length.
  Write("a.bin", "second, longer bytes");
  absl::StatusOr<v1::Digest> changed = memo.Get(a);
  ASSERT_TRUE(changed.ok()) << changed.status();
  EXPECT_EQ(changed->hash(), Sha256Hex("second, longer bytes"));
  // The same length, another file renamed over it (a new inode).
  const fs::path b = Write("b.bin", "second, LONGER bytes");
  fs::rename(b, a);
  absl::StatusOr<v1::Digest> replaced = memo.Get(a);
  ASSERT_TRUE(replaced.ok()) << replaced.status();
  EXPECT_EQ(replaced->hash(), Sha256Hex("second, LONGER bytes"));
  EXPECT_EQ(memo.bytes_hashed(), 11 + 20 + 20);
}

TEST_F(FileDigestMemoTest, AMissingFileIsAnErrorNamingIt) {
  FileDigestMemo memo;
  absl::StatusOr<v1::Digest> missing = memo.Get(dir_ / "nowhere.bin");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.status().message().find("nowhere.bin"), std::string::npos) << missing.status();
  // Created afterwards: hashed then, not remembered as missing.
  const fs::path late = Write("nowhere.bin", "here now");
  absl::StatusOr<v1::Digest> found = memo.Get(late);
  ASSERT_TRUE(found.ok()) << found.status();
  EXPECT_EQ(found->hash(), Sha256Hex("here now"));
}

TEST_F(FileDigestMemoTest, ModelsSharingFilesAreHashedOnceWithTheSameDigests) {
  const fs::path model = fs::path(IMPOSTOR_ASSETS_DIR) / "props_pbr/WaterBottle/glTF/WaterBottle.gltf";
  if (!fs::exists(model)) GTEST_SKIP() << "asset missing: " << model;
  absl::StatusOr<MeshFiles> files = CollectMeshFiles(model);
  ASSERT_TRUE(files.ok()) << files.status();
  absl::StatusOr<v1::MeshInput> alone = HashMesh(*files);
  ASSERT_TRUE(alone.ok()) << alone.status();
  FileDigestMemo memo;
  int64_t model_bytes = 0;
  for (int request = 0; request < 3; ++request) {
    absl::StatusOr<v1::MeshInput> shared = HashMesh(*files, memo);
    ASSERT_TRUE(shared.ok()) << shared.status();
    EXPECT_EQ(shared->SerializeAsString(), alone->SerializeAsString()) << "request " << request;
    if (request == 0) model_bytes = memo.bytes_hashed();
  }
  EXPECT_GT(model_bytes, 0);
  EXPECT_EQ(memo.bytes_hashed(), model_bytes) << "the model's files were hashed again";
}

}  // namespace
}  // namespace impostor::sdk
