// A full scratch during a job (worker/scratch_shortage.h): named, and ended
// as the job's fault (RESOURCE_EXHAUSTED: final, no retry, no worker pause)
// or the worker's (UNAVAILABLE: retried elsewhere), never left an unnamed,
// retryable INTERNAL. The full disk itself: scratch_tmpfs_test.cc.
#include "worker/scratch_shortage.h"

#include <cerrno>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace impostor {
namespace {

constexpr int64_t kMiB = 1 << 20;

ScratchSpace Space(int64_t capacity, int64_t available) {
  return {.capacity_bytes = capacity, .available_bytes = available, .block_bytes = 4096};
}

TEST(ScratchWriteError, OnlyNoSpaceAndQuotaAreMarkedFull) {
  for (int full : {ENOSPC, EDQUOT}) {
    const absl::Status s = ScratchWriteError("write", "/s/job-0/input/a.bin", full);
    EXPECT_TRUE(IsScratchFull(s)) << full;
    EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted) << full;
    EXPECT_EQ(std::string(s.message()).rfind("cannot write /s/job-0/input/a.bin: ", 0), 0u) << s;
  }
  for (int other : {EIO, EACCES, EROFS, ENOENT, ELOOP}) {
    const absl::Status s = ScratchWriteError("create", "/s/a", other);
    EXPECT_FALSE(IsScratchFull(s)) << other;
    EXPECT_EQ(s.code(), absl::StatusCode::kInternal) << other;
  }
  // The code alone does not make a full scratch: a mesh over the limits is
  // RESOURCE_EXHAUSTED too.
  EXPECT_FALSE(IsScratchFull(absl::ResourceExhaustedError("mesh: 30000000 triangles")));
}

TEST(AttributeScratchShortage, TheJobsFaultIsFinalTheWorkersIsRetried) {
  const absl::Status enospc = ScratchWriteError("write", "/s/job-0/input/a.bin", ENOSPC);
  const absl::Status png = absl::InternalError("cannot write /s/job-0/output/albedo.png");
  struct Case {
    const char* name;
    absl::Status failure;
    ScratchFacts facts;
    absl::StatusCode code;
    std::vector<std::string> needles;
  };
  const Case cases[] = {
      {"the job filled an empty scratch",
       enospc,
       {.at_start = Space(4 * kMiB, 4 * kMiB - 8192),
        .now = Space(4 * kMiB, 0),
        .job = {.bytes = 4 * kMiB - 8192, .inodes = 5},
        .inputs_need = 3 * kMiB},
       absl::StatusCode::kResourceExhausted,
       {"the job ran out of the worker's scratch /s by itself (the job's folder held 4186112 bytes; its inputs need "
        "3145728 bytes; 0 of 4194304 bytes available now, 4186112 when the job started)",
        "(cannot write /s/job-0/input/a.bin: No space left on device)"}},
      {"others filled it meanwhile",
       enospc,
       {.at_start = Space(4 * kMiB, 4 * kMiB), .now = Space(4 * kMiB, 0), .job = {.bytes = kMiB, .inodes = 3}},
       absl::StatusCode::kUnavailable,
       {"the worker's scratch /s ran out of space (the job's folder held 1048576 bytes; 0 of 4194304 bytes",
        "other files hold the rest): another worker may take it"}},
      {"others held most of it from the start",
       enospc,
       {.at_start = Space(4 * kMiB, kMiB), .now = Space(4 * kMiB, 0), .job = {.bytes = kMiB, .inodes = 3}},
       absl::StatusCode::kUnavailable,
       {"1048576 when the job started"}},
      {"an output writer's INTERNAL on a full scratch",
       png,
       {.at_start = Space(4 * kMiB, 4 * kMiB), .now = Space(4 * kMiB, 4096), .job = {.bytes = 4 * kMiB - 4096}},
       absl::StatusCode::kResourceExhausted,
       {"by itself", "(cannot write /s/job-0/output/albedo.png)"}},
      {"out of inodes, the job's own",
       png,
       {.at_start = Space(4 * kMiB, 4 * kMiB),
        .now = {.capacity_bytes = 4 * kMiB, .available_bytes = 3 * kMiB, .capacity_inodes = 100,
                .available_inodes = 0},
        .job = {.bytes = kMiB, .inodes = 99}},
       absl::StatusCode::kResourceExhausted,
       {"and 99 of its 100 inodes"}},
      {"out of inodes, others'",
       png,
       {.at_start = Space(4 * kMiB, 4 * kMiB),
        .now = {.capacity_bytes = 4 * kMiB, .available_bytes = 3 * kMiB, .capacity_inodes = 100,
                .available_inodes = 0},
        .job = {.bytes = kMiB, .inodes = 10}},
       absl::StatusCode::kUnavailable,
       {"and 10 of its 100 inodes"}},
  };
  for (const Case& c : cases) {
    const absl::Status s = AttributeScratchShortage(c.failure, c.facts, "/s");
    EXPECT_EQ(s.code(), c.code) << c.name << ": " << s;
    for (const std::string& needle : c.needles) {
      EXPECT_NE(std::string(s.message()).find(needle), std::string::npos) << c.name << ": " << s;
    }
  }
}

// Failures that are not a full scratch pass through untouched.
TEST(AttributeScratchShortage, LeavesOtherFailuresAlone) {
  const ScratchFacts full{.at_start = Space(4 * kMiB, 4 * kMiB), .now = Space(4 * kMiB, 0), .job = {.bytes = 4 * kMiB}};
  const ScratchFacts roomy{.at_start = Space(4 * kMiB, 4 * kMiB), .now = Space(4 * kMiB, 3 * kMiB), .job = {}};
  struct Case {
    const char* name;
    absl::Status failure;
    ScratchFacts facts;
  };
  const Case cases[] = {
      {"bad mesh on a full scratch", absl::InvalidArgumentError("mesh: not a glTF"), full},
      {"over the load limits on a full scratch", absl::ResourceExhaustedError("30000000 triangles"), full},
      {"cancelled on a full scratch", absl::CancelledError("cancelled while downloading"), full},
      {"a GPU fault with room to spare", absl::InternalError("vkQueueSubmit: VK_ERROR_DEVICE_LOST"), roomy},
      {"the refused inputs (already named)", absl::UnavailableError("inputs need 5 bytes"), full},
  };
  for (const Case& c : cases) {
    EXPECT_EQ(AttributeScratchShortage(c.failure, c.facts, "/s"), c.failure) << c.name;
  }
}

}  // namespace
}  // namespace impostor
