// The scratch measured against a job's inputs (worker/scratch_space.h):
// too big for the whole scratch is the job's fault (RESOURCE_EXHAUSTED,
// final), too big for what is free now is the worker's (UNAVAILABLE,
// retryable); both name the bytes needed, available and in all.
#include "worker/scratch_space.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

namespace impostor {
namespace {

namespace fs = std::filesystem;

fs::path FreshDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("scratch_space_test_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

TEST(CheckInputsFit, NamesNeededAvailableAndCapacity) {
  const ScratchSpace space{.capacity_bytes = 4'194'304,
                           .available_bytes = 1'000'000,
                           .block_bytes = 4096,
                           .capacity_inodes = 1000,
                           .available_inodes = 10};
  struct Case {
    const char* name;
    ScratchDemand demand;
    absl::StatusCode code;
    std::string needle;  // "" for OK
  };
  const Case cases[] = {
      {"fits", {.bytes = 1'000'000, .inodes = 10, .blob_count = 1, .path_count = 1}, absl::StatusCode::kOk, ""},
      {"over the capacity",
       {.bytes = 268'439'552, .inodes = 3, .blob_count = 2, .path_count = 4097},
       absl::StatusCode::kResourceExhausted,
       "inputs need 268439552 bytes (2 distinct blobs under 4097 paths) but the worker's scratch /s holds 4194304 "
       "bytes in all (1000000 available): the job cannot fit on this worker"},
      {"one byte over the capacity",
       {.bytes = 4'194'305, .inodes = 3, .blob_count = 1, .path_count = 1},
       absl::StatusCode::kResourceExhausted,
       "inputs need 4194305 bytes (1 distinct blob under 1 path) but the worker's scratch /s holds 4194304 bytes"},
      {"over what is free",
       {.bytes = 1'000'001, .inodes = 3, .blob_count = 1, .path_count = 2},
       absl::StatusCode::kUnavailable,
       "inputs need 1000001 bytes (1 distinct blob under 2 paths) but the worker's scratch /s has 1000000 of its "
       "4194304 bytes available (other files hold the rest)"},
      {"over the inodes in all",
       {.bytes = 10, .inodes = 1001, .blob_count = 1, .path_count = 1},
       absl::StatusCode::kResourceExhausted,
       "inputs need 1001 inodes (1 distinct blob under 1 path) but the worker's scratch /s holds 1000 inodes in all"},
      {"over the inodes free",
       {.bytes = 10, .inodes = 11, .blob_count = 1, .path_count = 1},
       absl::StatusCode::kUnavailable,
       "has 10 of its 1000 inodes available"},
  };
  for (const Case& c : cases) {
    const absl::Status s = CheckInputsFit(c.demand, space, "/s");
    EXPECT_EQ(s.code(), c.code) << c.name << ": " << s;
    EXPECT_NE(std::string(s.message()).find(c.needle), std::string::npos) << c.name << ": " << s;
  }
}

TEST(CheckInputsFit, AFilesystemWithoutAnInodeLimitChecksBytesOnly) {
  const ScratchSpace btrfs{.capacity_bytes = 1 << 30, .available_bytes = 1 << 30, .block_bytes = 4096};
  EXPECT_TRUE(CheckInputsFit({.bytes = 4096, .inodes = 5'000'000}, btrfs, "/s").ok());
}

TEST(MeasureScratch, SeesTheFilesystemAndNamesAMissingFolder) {
  const fs::path dir = FreshDir("measure");
  const absl::StatusOr<ScratchSpace> space = MeasureScratch(dir);
  ASSERT_TRUE(space.ok()) << space.status();
  EXPECT_GT(space->capacity_bytes, 0);
  EXPECT_GE(space->capacity_bytes, space->available_bytes);
  EXPECT_GT(space->block_bytes, 0);

  const absl::StatusOr<ScratchSpace> gone = MeasureScratch(dir / "gone");
  EXPECT_EQ(gone.status().code(), absl::StatusCode::kInternal);
  EXPECT_NE(gone.status().message().find((dir / "gone").string()), std::string::npos) << gone.status();
  fs::remove_all(dir);
}

TEST(BytesHeldUnder, CountsAHardLinkedFileOnce) {
  const fs::path dir = FreshDir("held");
  std::ofstream(dir / "a.bin", std::ios::binary) << std::string(100'000, 'x');
  const ScratchHeld one = BytesHeldUnder(dir);
  fs::create_directories(dir / "sub");
  for (int i = 0; i < 50; ++i) fs::create_hard_link(dir / "a.bin", dir / "sub" / ("l" + std::to_string(i)));
  const ScratchHeld linked = BytesHeldUnder(dir);
  EXPECT_GE(one.bytes, 100'000);
  EXPECT_EQ(one.inodes, 2);     // the folder and the file
  EXPECT_EQ(linked.inodes, 3);  // + "sub"; the 50 links add none
  EXPECT_LT(linked.bytes, one.bytes + 64 * 1024) << "50 links counted as 50 copies";
  EXPECT_EQ(BytesHeldUnder(dir / "missing").bytes, 0);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace impostor
