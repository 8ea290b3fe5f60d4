// The worker's scratch on a real full disk: a 4 MiB tmpfs the test mounts
// (as root; skipped otherwise, naming why). A write past its end is a
// marked full-scratch error naming the path, the measurements see the
// mount as it is, and the shortage is the job's fault when its folder
// filled the disk and the worker's when other files did.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "tests/integration/tmpfs_mount.h"
#include "worker/scratch_file.h"
#include "worker/scratch_shortage.h"
#include "worker/scratch_space.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

constexpr int64_t kMiB = 1 << 20;

fs::path FreshDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("scratch_tmpfs_test_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// Writes `bytes` of input at `path` until done or refused; the refusal.
absl::Status FillWithInput(const fs::path& path, int64_t bytes) {
  ScratchFile file;
  if (auto s = file.Create(path); !s.ok()) return s;
  const std::string chunk(64 * 1024, 'x');
  for (int64_t left = bytes; left > 0; left -= static_cast<int64_t>(chunk.size())) {
    if (auto s = file.Append(chunk); !s.ok()) return s;
  }
  return file.Close();
}

// A 4 MiB tmpfs mounted for one test, or the reason the test skips.
#define MOUNT_4M_OR_SKIP(mount_dir, tmpfs)                                                         \
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to mount a tmpfs for the scratch";            \
  testing::TmpfsMount tmpfs(mount_dir, "4m");                                                      \
  if (!tmpfs.mounted()) GTEST_SKIP() << "cannot mount a tmpfs on " << mount_dir << ": " << tmpfs.error()

TEST(ScratchOnTmpfs, AWritePastTheEndIsAMarkedFullScratchNamingThePath) {
  const fs::path mount_dir = FreshDir("write");
  MOUNT_4M_OR_SKIP(mount_dir, tmpfs);
  const absl::StatusOr<ScratchSpace> empty = MeasureScratch(mount_dir);
  ASSERT_TRUE(empty.ok()) << empty.status();
  EXPECT_EQ(empty->capacity_bytes, 4 * kMiB);
  EXPECT_EQ(empty->available_bytes, 4 * kMiB);

  const fs::path input = mount_dir / "job-0/input/big.bin";
  const absl::Status s = FillWithInput(input, 5 * kMiB);
  EXPECT_TRUE(IsScratchFull(s)) << s;
  EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted) << s;
  EXPECT_EQ(std::string(s.message()), "cannot write " + input.string() + ": No space left on device");
  EXPECT_EQ(MeasureScratch(mount_dir)->available_bytes, 0);
  EXPECT_EQ(BytesHeldUnder(mount_dir / "job-0").bytes, 4 * kMiB) << "the job's folder holds the whole mount";
}

TEST(ScratchOnTmpfs, AJobThatFillsTheScratchByItselfFailsForGood) {
  const fs::path mount_dir = FreshDir("own");
  MOUNT_4M_OR_SKIP(mount_dir, tmpfs);
  const fs::path job = mount_dir / "job-0";
  const ScratchSpace at_start = *MeasureScratch(mount_dir);
  const absl::Status failed = FillWithInput(job / "input/big.bin", 5 * kMiB);
  ASSERT_TRUE(IsScratchFull(failed)) << failed;
  const absl::Status s = AttributeScratchShortage(
      failed, {.at_start = at_start, .now = *MeasureScratch(job), .job = BytesHeldUnder(job), .inputs_need = 5 * kMiB},
      mount_dir);
  EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted) << s;
  EXPECT_NE(s.message().find("the job ran out of the worker's scratch " + mount_dir.string() +
                             " by itself (the job's folder held 4194304 bytes; its inputs need 5242880 bytes; 0 of "
                             "4194304 bytes available now, 4194304 when the job started)"),
            std::string::npos)
      << s;
}

TEST(ScratchOnTmpfs, AScratchFilledByOtherFilesIsTheWorkersAndRetried) {
  const fs::path mount_dir = FreshDir("others");
  MOUNT_4M_OR_SKIP(mount_dir, tmpfs);
  std::ofstream(mount_dir / "filler", std::ios::binary) << std::string(3 * kMiB, 'f');
  const fs::path job = mount_dir / "job-0";
  const ScratchSpace at_start = *MeasureScratch(mount_dir);
  EXPECT_EQ(at_start.available_bytes, kMiB);
  // What the worker checks first: these inputs fit the mount, not what is free.
  const absl::Status refused = CheckInputsFit({.bytes = 2 * kMiB, .inodes = 3, .blob_count = 1, .path_count = 1},
                                              at_start, mount_dir);
  EXPECT_EQ(refused.code(), absl::StatusCode::kUnavailable) << refused;
  EXPECT_NE(refused.message().find("has 1048576 of its 4194304 bytes available"), std::string::npos) << refused;
  // Filled anyway (as by a neighbour growing while the job downloads).
  const absl::Status failed = FillWithInput(job / "input/a.bin", 2 * kMiB);
  ASSERT_TRUE(IsScratchFull(failed)) << failed;
  const absl::Status s = AttributeScratchShortage(
      failed, {.at_start = at_start, .now = *MeasureScratch(job), .job = BytesHeldUnder(job), .inputs_need = 2 * kMiB},
      mount_dir);
  EXPECT_EQ(s.code(), absl::StatusCode::kUnavailable) << s;
  EXPECT_NE(s.message().find("the worker's scratch " + mount_dir.string() +
                             " ran out of space (the job's folder held 1048576 bytes; its inputs need 2097152 bytes; "
                             "0 of 4194304 bytes available now, 1048576 when the job started; other files hold the "
                             "rest)"),
            std::string::npos)
      << s;
}

}  // namespace
}  // namespace impostor
