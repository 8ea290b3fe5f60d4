// EarlySync (client/base/early_sync.h): a large finished file handed over is
// synced on its own thread, through its own duplicate of the descriptor; a
// small one is left to the caller; a failed sync is kept and named, and no
// later Add hides it.
#include "client/base/early_sync.h"

#include <fcntl.h>
#include <unistd.h>

#include <filesystem>
#include <iterator>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "client/base/unique_fd.h"
#include "tests/support/scratch_root.h"

namespace impostor::sdk {
namespace {

namespace fs = std::filesystem;

// A file of `size` bytes under the scratch root, open for writing.
UniqueFd WrittenFile(const std::string& name, int64_t size) {
  const fs::path path = impostor::testing::ScratchRoot() / name;
  UniqueFd fd(::open(path.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
  EXPECT_TRUE(fd.valid()) << path;
  const std::string block(64 << 10, 'x');
  for (int64_t left = size; left > 0; left -= static_cast<int64_t>(block.size())) {
    const size_t n = static_cast<size_t>(std::min<int64_t>(left, static_cast<int64_t>(block.size())));
    EXPECT_EQ(::write(fd.get(), block.data(), n), static_cast<ssize_t>(n));
  }
  return fd;
}

TEST(EarlySync, NothingHandedOverIsOk) {
  EarlySync sync;
  EXPECT_TRUE(sync.Finish().ok());
  EXPECT_EQ(sync.synced(), 0);
}

TEST(EarlySync, SyncsLargeFilesAndLeavesSmallOnesToTheCaller) {
  EarlySync sync;
  UniqueFd large = WrittenFile("large.bin", EarlySync::kMinBytes);
  UniqueFd small = WrittenFile("small.bin", EarlySync::kMinBytes - 1);
  sync.Add(large.get(), EarlySync::kMinBytes, "large.bin");
  sync.Add(small.get(), EarlySync::kMinBytes - 1, "small.bin");
  // The caller may close its own descriptor at once: the sync has its own.
  large.Reset();
  ASSERT_TRUE(sync.Finish().ok());
  EXPECT_EQ(sync.synced(), 1);
  // More after a Finish are synced too.
  UniqueFd second = WrittenFile("second.bin", 3 << 20);
  sync.Add(second.get(), 3 << 20, "second.bin");
  ASSERT_TRUE(sync.Finish().ok());
  EXPECT_EQ(sync.synced(), 2);
}

TEST(EarlySync, AClosedDescriptorIsSkipped) {
  EarlySync sync;
  sync.Add(-1, 8 << 20, "none.bin");
  EXPECT_TRUE(sync.Finish().ok());
  EXPECT_EQ(sync.synced(), 0);
}

TEST(EarlySync, AFailedSyncIsKeptAndNamesTheFile) {
  // fdatasync of a pipe fails (EINVAL): the stand-in for a disk's EIO.
  int fds[2];
  ASSERT_EQ(::pipe2(fds, O_CLOEXEC), 0);
  UniqueFd read_end(fds[0]), write_end(fds[1]);
  EarlySync sync;
  sync.Add(read_end.get(), 4 << 20, "out/albedo_alpha.png");
  const absl::Status failed = sync.Finish();
  EXPECT_EQ(failed.code(), absl::StatusCode::kInternal) << failed;
  EXPECT_NE(std::string(failed.message()).find("cannot sync out/albedo_alpha.png"), std::string::npos) << failed;
  // A file handed over afterwards does not clear it: the caller's own sync
  // of the failed file might succeed with its bytes lost.
  UniqueFd good = WrittenFile("good.bin", 2 << 20);
  sync.Add(good.get(), 2 << 20, "good.bin");
  EXPECT_EQ(sync.Finish(), failed);
  EXPECT_EQ(sync.synced(), 0);
}

// Open descriptors of this process.
size_t OpenDescriptors() {
  return static_cast<size_t>(std::distance(fs::directory_iterator("/proc/self/fd"), fs::directory_iterator{}));
}

TEST(EarlySync, DroppedWithFilesWaitingClosesEveryDuplicate) {
  const size_t before = OpenDescriptors();
  {
    std::vector<UniqueFd> files;
    EarlySync sync;
    for (int i = 0; i < 12; ++i) {
      files.push_back(WrittenFile("many" + std::to_string(i) + ".bin", 1 << 20));
      sync.Add(files.back().get(), 1 << 20, "many.bin");
    }
  }  // the destructor drops what waits (kMaxPending kept at most) and joins
  EXPECT_EQ(OpenDescriptors(), before);
}

}  // namespace
}  // namespace impostor::sdk
