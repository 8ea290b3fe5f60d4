// Input files in a job's scratch folder: a blob written once
// (worker/scratch_file.h) and shown under its other paths by links
// (worker/input_links.h), with the path checks every input path gets.
#include "worker/input_links.h"

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "worker/scratch_file.h"
#include "worker/scratch_space.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

fs::path FreshDir(const fs::path& parent, const std::string& name) {
  const fs::path dir = parent / ("input_links_test_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string Read(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

absl::Status WriteInput(const fs::path& path, const std::string& bytes) {
  ScratchFile file;
  if (auto s = file.Create(path); !s.ok()) return s;
  if (auto s = file.Append(bytes); !s.ok()) return s;
  return file.Close();
}

TEST(LinkInputCopies, FourThousandPathsShareOneCopyOfTheBytes) {
  const fs::path input = FreshDir(fs::temp_directory_path(), "many");
  const std::string blob(256 * 1024, 'b');
  ASSERT_TRUE(WriteInput(input / "pad/p0.bin", blob).ok());
  std::vector<fs::path> others;
  for (int i = 1; i < 4096; ++i) others.push_back(input / absl::StrCat("pad/p", i, ".bin"));
  ASSERT_TRUE(LinkInputCopies(input / "pad/p0.bin", others).ok());

  struct stat st {};
  ASSERT_EQ(::stat((input / "pad/p0.bin").c_str(), &st), 0);
  EXPECT_EQ(st.st_nlink, 4096u);
  EXPECT_EQ(Read(input / "pad/p4095.bin"), blob);
  // On disk: the bytes once (plus the folder's entries), not 4096 times.
  const ScratchHeld held = BytesHeldUnder(input);
  EXPECT_LT(held.bytes, 2 * static_cast<int64_t>(blob.size())) << "bytes under " << input;
  EXPECT_EQ(held.inodes, 3);  // input, pad, the blob
  fs::remove_all(input);
}

TEST(LinkInputCopies, RefusesPathsThatCollideOrCrossAFile) {
  const fs::path input = FreshDir(fs::temp_directory_path(), "bad");
  ASSERT_TRUE(WriteInput(input / "a.bin", "bytes").ok());
  ASSERT_TRUE(WriteInput(input / "file", "a file, not a folder").ok());
  struct Case {
    const char* name;
    fs::path other;
    absl::StatusCode code;
    std::string needle;
  };
  const Case cases[] = {
      {"a folder that is a file", input / "file/b.bin", absl::StatusCode::kInvalidArgument,
       "cannot create the folder for input b.bin"},
      {"a path taken by another input", input / "file", absl::StatusCode::kInvalidArgument,
       "input " + (input / "file").string() + " is listed twice"},
      {"the written path itself", input / "a.bin", absl::StatusCode::kInvalidArgument, "is listed twice"},
  };
  for (const Case& c : cases) {
    const absl::Status s = LinkInputCopies(input / "a.bin", std::vector<fs::path>{c.other});
    EXPECT_EQ(s.code(), c.code) << c.name << ": " << s;
    EXPECT_NE(std::string(s.message()).find(c.needle), std::string::npos) << c.name << ": " << s;
  }
  EXPECT_EQ(Read(input / "file"), "a file, not a folder") << "a refused link changed the other input";
  // A missing source is a failed link, named, not a crash.
  const absl::Status missing = LinkInputCopies(input / "never-written", std::vector<fs::path>{input / "c.bin"});
  EXPECT_EQ(missing.code(), absl::StatusCode::kInternal) << missing;
  EXPECT_NE(missing.message().find("cannot link " + (input / "c.bin").string()), std::string::npos) << missing;
  fs::remove_all(input);
}

// Where a hard link is impossible (another filesystem here), a symlink to
// the written copy shows the same bytes.
TEST(LinkInputCopies, FallsBackToASymlinkWhereHardLinksCannotGo) {
  const fs::path shm = "/dev/shm";
  if (!fs::is_directory(shm)) GTEST_SKIP() << "no /dev/shm for a second filesystem";
  const fs::path here = FreshDir(fs::temp_directory_path(), "xdev_here");
  const fs::path there = FreshDir(shm, "xdev_there");
  struct stat a {}, b {};
  ASSERT_EQ(::stat(here.c_str(), &a), 0);
  ASSERT_EQ(::stat(there.c_str(), &b), 0);
  if (a.st_dev == b.st_dev) GTEST_SKIP() << here << " and " << there << " are one filesystem: hard links work";
  ASSERT_TRUE(WriteInput(there / "blob.bin", "shared bytes").ok());
  ASSERT_TRUE(LinkInputCopies(there / "blob.bin", std::vector<fs::path>{here / "x/copy.bin"}).ok());
  EXPECT_TRUE(fs::is_symlink(here / "x/copy.bin"));
  EXPECT_EQ(Read(here / "x/copy.bin"), "shared bytes");
  fs::remove_all(here);
  fs::remove_all(there);
}

TEST(ScratchFile, WritesCreatesFoldersAndNamesWhatWentWrong) {
  const fs::path input = FreshDir(fs::temp_directory_path(), "file");
  ASSERT_TRUE(WriteInput(input / "a/b/c.bin", "abc").ok());
  EXPECT_EQ(Read(input / "a/b/c.bin"), "abc");

  ScratchFile unopened;
  EXPECT_EQ(unopened.Append("x").code(), absl::StatusCode::kFailedPrecondition);

  // A folder in the way is the request's fault (issue 23), not a crash.
  const absl::Status through_file = WriteInput(input / "a/b/c.bin/d.bin", "x");
  EXPECT_EQ(through_file.code(), absl::StatusCode::kInvalidArgument) << through_file;
  EXPECT_NE(through_file.message().find("cannot create the folder for input d.bin"), std::string::npos)
      << through_file;

  // Never written through a symlink: the file it points at stays as it was.
  std::ofstream(input / "outside.txt") << "keep";
  fs::create_symlink(input / "outside.txt", input / "link.bin");
  const absl::Status through_link = WriteInput(input / "link.bin", "overwrite");
  EXPECT_EQ(through_link.code(), absl::StatusCode::kInternal) << through_link;
  EXPECT_NE(through_link.message().find("cannot create " + (input / "link.bin").string()), std::string::npos)
      << through_link;
  EXPECT_EQ(Read(input / "outside.txt"), "keep");
  fs::remove_all(input);
}

}  // namespace
}  // namespace impostor
