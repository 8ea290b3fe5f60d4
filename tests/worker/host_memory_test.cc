// worker/host_memory.h on made-up /proc and cgroup trees: the least bound
// wins and is named, for cgroup v2 and v1, RLIMIT_AS and the machine.
#include "worker/host_memory.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

namespace impostor {
namespace {

namespace fs = std::filesystem;

class HostMemoryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() /
            ("impostor_host_memory_" + std::to_string(::getpid()) + "_" +
             ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root_);
    sources_ = {.proc = root_ / "proc", .cgroup = root_ / "cgroup", .address_space_limit = 0};
    // A 16 GB machine with 12 GB available.
    Write("proc/meminfo", "MemTotal:       15625000 kB\nMemFree:         1000000 kB\nMemAvailable:   11718750 kB\n");
  }
  void TearDown() override { fs::remove_all(root_); }

  void Write(const std::string& path, const std::string& text) {
    fs::create_directories((root_ / path).parent_path());
    std::ofstream(root_ / path) << text;
  }

  fs::path root_;
  HostMemorySources sources_;
};

TEST_F(HostMemoryTest, TheMachineAloneIsMemTotalAndMemAvailable) {
  absl::StatusOr<HostMemory> m = MeasureHostMemory(sources_);
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_EQ(m->total_bytes, 16'000'000'000);
  EXPECT_EQ(m->total_bound, "MemTotal");
  EXPECT_EQ(m->available_bytes, 12'000'000'000);
  EXPECT_EQ(m->available_bound, "MemAvailable");
}

TEST_F(HostMemoryTest, CgroupV2TheTightestLimitUpTheTreeLessWhatItUses) {
  Write("proc/self/cgroup", "0::/workers/worker-1\n");
  Write("cgroup/cgroup.controllers", "cpu memory\n");
  Write("cgroup/workers/memory.max", "8000000000\n");
  Write("cgroup/workers/memory.current", "3000000000\n");
  // Reclaimable page cache is not in use for this purpose.
  Write("cgroup/workers/memory.stat", "anon 2000000000\nactive_file 1\ninactive_file 1000000000\n");
  Write("cgroup/workers/worker-1/memory.max", "max\n");
  Write("cgroup/workers/worker-1/memory.current", "2500000000\n");
  absl::StatusOr<HostMemory> m = MeasureHostMemory(sources_);
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_EQ(m->total_bytes, 8'000'000'000);
  EXPECT_EQ(m->total_bound, "cgroup memory.max");
  EXPECT_EQ(m->available_bytes, 6'000'000'000);
  EXPECT_EQ(m->available_bound, "cgroup memory.max less memory.current");
}

TEST_F(HostMemoryTest, CgroupV1MemoryControllerBesideAHybridV2) {
  Write("proc/self/cgroup", "4:memory:/job\n1:cpu:/\n0::/job\n");
  Write("cgroup/memory/memory.limit_in_bytes", "9223372036854771712\n");  // v1's "no limit"
  Write("cgroup/memory/job/memory.limit_in_bytes", "4000000000\n");
  Write("cgroup/memory/job/memory.usage_in_bytes", "1000000000\n");
  Write("cgroup/memory/job/memory.stat", "cache 1\ntotal_inactive_file 500000000\n");
  fs::create_directories(root_ / "cgroup/unified/job");  // v2 without the memory controller
  absl::StatusOr<HostMemory> m = MeasureHostMemory(sources_);
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_EQ(m->total_bytes, 4'000'000'000);
  EXPECT_EQ(m->total_bound, "cgroup memory.limit_in_bytes");
  EXPECT_EQ(m->available_bytes, 3'500'000'000);
}

TEST_F(HostMemoryTest, AnAddressSpaceLimitCountsWhatTheProcessHasMapped) {
  sources_.address_space_limit = 6'000'000'000;
  Write("proc/self/status", "Name:\tworker\nVmPeak:\t 3000000 kB\nVmSize:\t 2000000 kB\n");
  absl::StatusOr<HostMemory> m = MeasureHostMemory(sources_);
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_EQ(m->total_bytes, 6'000'000'000);
  EXPECT_EQ(m->total_bound, "RLIMIT_AS");
  EXPECT_EQ(m->available_bytes, 6'000'000'000 - 2'048'000'000);
  EXPECT_EQ(m->available_bound, "RLIMIT_AS less VmSize");
}

TEST_F(HostMemoryTest, NoMeminfoIsAnErrorNamingTheFile) {
  fs::remove(root_ / "proc/meminfo");
  absl::StatusOr<HostMemory> m = MeasureHostMemory(sources_);
  EXPECT_EQ(m.status().code(), absl::StatusCode::kInternal);
  EXPECT_NE(m.status().message().find((root_ / "proc/meminfo").string()), std::string::npos) << m.status();
}

TEST(HostMemoryOfThisProcess, IsReadable) {
  absl::StatusOr<HostMemory> m = MeasureHostMemory();
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_GT(m->total_bytes, 0);
  EXPECT_LE(m->available_bytes, m->total_bytes);
}

}  // namespace
}  // namespace impostor
