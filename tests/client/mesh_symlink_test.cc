// CollectMeshFiles and symbolic links (issue 23): a link that leads out of
// the model's folder is refused, naming the link and its target, unless
// CollectOptions::follow_symlinks (the CLI's --follow-symlinks); links that
// stay inside the folder are followed. The flag's parsing is at the end.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "client/cli/cli_args.h"
#include "client/transfer/mesh_files.h"

namespace impostor::sdk {
namespace {

namespace fs = std::filesystem;

class MeshSymlinkTest : public testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("impostor_mesh_symlink_" + std::to_string(::getpid()) + "_" +
                                         testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root_);
    fs::create_directories(root_ / "model" / "textures");
    fs::create_directories(root_ / "secrets");
    std::ofstream(root_ / "secrets" / "id_rsa") << "PRIVATE KEY";
    std::ofstream(root_ / "model" / "real.png") << "png";
    std::ofstream(root_ / "model" / "m.bin") << "bin";
  }
  void TearDown() override { fs::remove_all(root_); }

  fs::path Model(const std::string& image_uri) {
    const fs::path p = root_ / "model" / "m.gltf";
    std::ofstream(p) << R"({"asset":{"version":"2.0"},"buffers":[{"uri":"m.bin","byteLength":3}],"images":[{"uri":")"
                     << image_uri << R"("}]})";
    return p;
  }
  fs::path root_;
};

TEST_F(MeshSymlinkTest, LinkOutOfTheFolderIsRefusedNamingLinkAndTarget) {
  fs::create_symlink(root_ / "secrets" / "id_rsa", root_ / "model" / "tex.png");
  const absl::StatusOr<MeshFiles> files = CollectMeshFiles(Model("tex.png"));
  ASSERT_FALSE(files.ok()) << "a link to a secret was accepted";
  EXPECT_EQ(files.status().code(), absl::StatusCode::kPermissionDenied) << files.status();
  const std::string message(files.status().message());
  EXPECT_NE(message.find((root_ / "model" / "tex.png").string() + " (images[0].uri"), std::string::npos) << message;
  EXPECT_NE(message.find("is a symbolic link to " + (root_ / "secrets" / "id_rsa").string()), std::string::npos)
      << message;
  EXPECT_NE(message.find("--follow-symlinks"), std::string::npos) << message;
}

TEST_F(MeshSymlinkTest, RelativeLinkAndLinkedDirectoryAreRefusedToo) {
  struct Case {
    const char* name;
    fs::path target;  // as written into the link
    fs::path link;    // relative to model/
    const char* uri;
  };
  const Case cases[] = {
      {"relative link", "../secrets/id_rsa", "rel.png", "rel.png"},
      {"linked directory", root_ / "secrets", "textures/linked", "textures/linked/id_rsa"},
      {"chain of links", "rel2.png", "chain.png", "chain.png"},
  };
  fs::create_symlink("../secrets/id_rsa", root_ / "model" / "rel2.png");
  for (const Case& c : cases) {
    fs::create_symlink(c.target, root_ / "model" / c.link);
    const absl::StatusOr<MeshFiles> files = CollectMeshFiles(Model(c.uri));
    EXPECT_EQ(files.status().code(), absl::StatusCode::kPermissionDenied) << c.name << ": " << files.status();
    EXPECT_NE(files.status().message().find("is a symbolic link to"), std::string::npos)
        << c.name << ": " << files.status();
  }
}

TEST_F(MeshSymlinkTest, FollowSymlinksUploadsTheTarget) {
  fs::create_symlink(root_ / "secrets" / "id_rsa", root_ / "model" / "tex.png");
  const absl::StatusOr<MeshFiles> files = CollectMeshFiles(Model("tex.png"), {.follow_symlinks = true});
  ASSERT_TRUE(files.ok()) << files.status();
  ASSERT_EQ(files->files.size(), 2u);
  EXPECT_EQ(files->files[1].relative_path, "tex.png");
}

TEST_F(MeshSymlinkTest, LinksInsideTheFolderAreFollowed) {
  fs::create_symlink("real.png", root_ / "model" / "alias.png");
  const absl::StatusOr<MeshFiles> files = CollectMeshFiles(Model("alias.png"));
  ASSERT_TRUE(files.ok()) << files.status();
  EXPECT_EQ(files->files.size(), 2u);
}

}  // namespace
}  // namespace impostor::sdk

// The CLI flag that sets CollectOptions::follow_symlinks (through
// BakeSettings::follow_symlinks), for bake and bake-batch; off by default,
// refused where it means nothing.
namespace impostor::cli {
namespace {

TEST(FollowSymlinksFlag, BakeAndBakeBatchTakeItOthersRefuseIt) {
  EXPECT_FALSE(ParseCliArgs({"bake", "m.gltf", "--out", "o"}, nullptr)->follow_symlinks);
  EXPECT_TRUE(ParseCliArgs({"bake", "m.gltf", "--out", "o", "--follow-symlinks"}, nullptr)->follow_symlinks);
  EXPECT_TRUE(ParseCliArgs({"bake-batch", "s.json", "--out", "o", "--follow-symlinks"}, nullptr)->follow_symlinks);
  EXPECT_FALSE(ParseCliArgs({"status", "j1", "--follow-symlinks"}, nullptr).ok());
  EXPECT_FALSE(ParseCliArgs({"bake", "m.gltf", "--out", "o", "--follow-symlinks=yes"}, nullptr).ok());
}

}  // namespace
}  // namespace impostor::cli
