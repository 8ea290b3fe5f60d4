// The client's wording of local I/O errors: a full disk or quota is
// RESOURCE_EXHAUSTED naming the path and the free space, anything else
// INTERNAL (the full disk itself: tests/integration/client_disk_full_test.cc).
#include "client/base/local_io_error.h"

#include <cerrno>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

namespace impostor::sdk {
namespace {

TEST(LocalIoError, AFullDiskOrQuotaNamesThePathAndTheFreeSpace) {
  const std::filesystem::path file = std::filesystem::temp_directory_path() / "not-created-yet" / "a.png";
  for (int err : {ENOSPC, EDQUOT}) {
    const absl::Status s = LocalIoError("cannot write", file, err);
    EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted) << s;
    const std::string m(s.message());
    EXPECT_EQ(m.rfind("cannot write " + file.string() + ": ", 0), 0u) << m;
    EXPECT_NE(m.find(" bytes free on its filesystem); free space and try again"), std::string::npos) << m;
    EXPECT_TRUE(IsLocalDiskFull(s));
  }
}

TEST(LocalIoError, OtherErrorsAreInternalAndSayNothingOfSpace) {
  for (int err : {EIO, EACCES, EROFS, ENOENT}) {
    const absl::Status s = LocalIoError("cannot open", "/some/file", err);
    EXPECT_EQ(s.code(), absl::StatusCode::kInternal) << s;
    EXPECT_EQ(std::string(s.message()).find("free"), std::string::npos) << s;
    EXPECT_FALSE(IsLocalDiskFull(s));
  }
  EXPECT_FALSE(IsLocalDiskFull(absl::OkStatus()));
}

}  // namespace
}  // namespace impostor::sdk
