// The wording of a full-disk error and the free-space probe behind it (the
// full disk itself: tests/integration/disk_full_test.cc).
#include "server/disk_full.h"

#include <cerrno>
#include <filesystem>

#include <gtest/gtest.h>

namespace impostor {
namespace {

TEST(DiskFullError, OnlyNoSpaceAndQuotaCount) {
  EXPECT_TRUE(IsDiskFull(ENOSPC));
  EXPECT_TRUE(IsDiskFull(EDQUOT));
  for (int other : {0, EIO, EACCES, EROFS, ENOENT}) EXPECT_FALSE(IsDiskFull(other)) << other;
}

TEST(DiskFullError, FreeBytesAsksTheNearestExistingFolder) {
  const std::filesystem::path tmp = std::filesystem::temp_directory_path();
  const int64_t here = FreeBytes(tmp);
  EXPECT_GT(here, 0);
  // A file not yet created is on its folder's filesystem.
  EXPECT_GT(FreeBytes(tmp / "not-created-yet" / "blob.tmp"), 0);
}

TEST(DiskFullError, TheErrorNamesThePathTheCauseAndTheFreeSpace) {
  const std::filesystem::path file = std::filesystem::temp_directory_path() / "x.tmp";
  const absl::Status s = DiskFullError("write", file, "No space left on device");
  EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted);
  const std::string m(s.message());
  EXPECT_EQ(m.rfind("write " + file.string() + ": No space left on device (", 0), 0u) << m;
  EXPECT_NE(m.find(" bytes free on its filesystem); free space or raise the quota"), std::string::npos) << m;
}

}  // namespace
}  // namespace impostor
