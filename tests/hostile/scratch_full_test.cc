// A worker's scratch under attack, through a real impostor-server and real
// impostor-worker processes, the worker's --scratch on a small tmpfs that
// the test mounts (as root; skipped otherwise, naming why):
//  * one uploaded blob listed under 4096 paths is written once (it used to
//    be written 4096 times: a 256 KiB upload asked for 1 GiB of scratch);
//  * inputs larger than the whole scratch fail the job for good,
//    RESOURCE_EXHAUSTED naming the bytes, and do not pause the worker (an
//    unnamed, retryable INTERNAL used to, three jobs for 5 minutes);
//  * inputs that fit the scratch but not what other files left free are
//    the worker's state: UNAVAILABLE naming the bytes, retried on another
//    worker while the full one is paused.
// Every wait is for a job event (WatchJob); the worker pauses at its render
// stage while a test file exists, so the scratch is looked at mid-job.
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "tests/support/server_process.h"
#include "tests/integration/tmpfs_mount.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::ServerProcess;

constexpr int64_t kMiB = 1 << 20;
constexpr char kBox[] = "props_pbr/Box/glTF-Binary/Box.glb";

// A worker whose leases of one job ended badly is paused for an hour: a
// retryable failure shows at once, as a worker that takes no more jobs.
const std::vector<std::string> kPauseAfterOneFailure = {"--worker-failure-limit=1", "--worker-pause-seconds=3600"};

std::string RandomBytes(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::string s(n, '\0');
  for (char& c : s) c = static_cast<char>(rng());
  return s;
}

// Adds `bytes` (uploaded) to `mesh` under each of `paths`.
void AddInput(ServerProcess& server, v1::MeshInput& mesh, const std::string& bytes,
              const std::vector<std::string>& paths) {
  const v1::Digest digest = testing::DigestOf(bytes);
  ASSERT_TRUE(testing::UploadBytes(server.assets(), bytes, digest).ok());
  for (const std::string& path : paths) {
    v1::InputFile* f = mesh.add_files();
    f->set_path(path);
    *f->mutable_digest() = digest;
  }
}

std::string Submit(ServerProcess& server, const v1::MeshInput& mesh, uint32_t resolution) {
  return testing::SubmitSmallBake(server.bake(), mesh, /*frames=*/3, resolution);
}

int64_t UsedBytes(const fs::path& mount) {
  struct statvfs st {};
  EXPECT_EQ(::statvfs(mount.c_str(), &st), 0);
  return static_cast<int64_t>(st.f_blocks - st.f_bfree) * static_cast<int64_t>(st.f_frsize);
}

// A tmpfs of `size` for the worker's scratch, or the reason the test skips.
#define MOUNT_SCRATCH_OR_SKIP(mount_dir, size, tmpfs)                                              \
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to mount a tmpfs for the worker's scratch";   \
  testing::TmpfsMount tmpfs(mount_dir, size);                                                      \
  if (!tmpfs.mounted()) GTEST_SKIP() << "cannot mount a tmpfs on " << mount_dir << ": " << tmpfs.error()

TEST(ScratchFull, OneBlobUnder4096PathsIsWrittenOnceAndBakes) {
  const fs::path dir = testing::NewTempDir("scratch_many_paths");
  const fs::path mount_dir = dir / "mount";
  fs::create_directories(mount_dir);
  MOUNT_SCRATCH_OR_SKIP(mount_dir, "8m", tmpfs);
  const fs::path scratch = mount_dir / "scratch";
  const fs::path pause = dir / "pause";
  std::ofstream(pause) << "pause";
  ServerProcess server(/*local_workers=*/0);
  auto worker = testing::StartWorker(server.address(), {"--scratch=" + scratch.string()},
                                     {"IMPOSTOR_WORKER_TEST_PAUSE_FILE=" + pause.string()});

  v1::MeshInput mesh = testing::UploadGlb(server.assets(), testing::AssetsDir() / kBox);
  const std::string pad = RandomBytes(256 * 1024, 1);
  std::vector<std::string> paths;
  for (int i = 0; i < 4096; ++i) paths.push_back(absl::StrCat("pad/p", i, ".bin"));
  AddInput(server, mesh, pad, paths);
  const std::string id = Submit(server, mesh, 64);

  const v1::Job paused = testing::WatchUntil(server.bake(), id, [](const v1::Job& j) {
    return testing::IsTerminalState(j.state()) || (j.state() == v1::JOB_STATE_RUNNING && j.stage() == "render");
  });
  ASSERT_EQ(paused.stage(), "render") << "state " << paused.state() << ": " << paused.error().message();
  // Every path is there, with the blob's bytes, and the bytes are there once.
  const fs::path input = scratch / "job-0" / "input";
  struct stat st {};
  ASSERT_EQ(::stat((input / "pad/p0.bin").c_str(), &st), 0);
  EXPECT_EQ(st.st_nlink, 4096u);
  EXPECT_EQ(testing::ReadFileBytes(input / "pad/p4095.bin"), pad);
  EXPECT_LT(UsedBytes(mount_dir), 2 * static_cast<int64_t>(pad.size())) << "scratch use while the job runs";

  fs::remove(pause);
  const v1::Job done = testing::WatchToEnd(server.bake(), id);
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
  EXPECT_EQ(done.attempts(), 1u);
}

TEST(ScratchFull, InputsLargerThanTheScratchFailForGoodAndTheWorkerServesOn) {
  const fs::path mount_dir = testing::NewTempDir("scratch_too_small");
  MOUNT_SCRATCH_OR_SKIP(mount_dir, "4m", tmpfs);
  const fs::path scratch = mount_dir / "scratch";
  ServerProcess server(/*local_workers=*/0, kPauseAfterOneFailure);
  auto worker = testing::StartWorker(server.address(), {"--name=small", "--scratch=" + scratch.string()});

  // Two distinct 3 MiB blobs (one of them listed twice): each fits the
  // 4 MiB scratch, the two together do not.
  v1::MeshInput mesh = testing::UploadGlb(server.assets(), testing::AssetsDir() / kBox);
  AddInput(server, mesh, RandomBytes(3 * kMiB, 2), {"a.bin", "again/a.bin"});
  AddInput(server, mesh, RandomBytes(3 * kMiB, 3), {"b.bin"});
  const v1::Job failed = testing::WatchUntil(server.bake(), Submit(server, mesh, 64), testing::EndedOrRequeued);
  ASSERT_EQ(failed.state(), v1::JOB_STATE_FAILED) << "retried: " << failed.DebugString();
  EXPECT_EQ(failed.error().code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << failed.error().message();
  EXPECT_EQ(failed.attempts(), 1u);
  const std::string& message = failed.error().message();
  EXPECT_NE(message.find("inputs need "), std::string::npos) << message;
  EXPECT_NE(message.find(" bytes (3 distinct blobs under 4 paths) but the worker's scratch " + scratch.string() +
                         " holds 4194304 bytes in all ("),
            std::string::npos)
      << message;

  // Not held against the worker: it bakes the next job.
  const v1::Job next = testing::WatchToEnd(
      server.bake(), Submit(server, testing::UploadGlb(server.assets(), testing::AssetsDir() / kBox), 72));
  EXPECT_EQ(next.state(), v1::JOB_STATE_SUCCEEDED) << next.error().message();
  EXPECT_EQ(next.worker_id(), failed.worker_id());
}

TEST(ScratchFull, AScratchFilledByOtherFilesSendsTheJobToAnotherWorker) {
  const fs::path mount_dir = testing::NewTempDir("scratch_filled");
  MOUNT_SCRATCH_OR_SKIP(mount_dir, "4m", tmpfs);
  std::ofstream(mount_dir / "filler", std::ios::binary) << std::string(3 * kMiB, 'f');
  ServerProcess server(/*local_workers=*/0, kPauseAfterOneFailure);
  auto full = testing::StartWorker(server.address(), {"--name=full", "--scratch=" + (mount_dir / "scratch").string()});

  v1::MeshInput mesh = testing::UploadGlb(server.assets(), testing::AssetsDir() / kBox);
  AddInput(server, mesh, RandomBytes(2 * kMiB, 4), {"pad.bin"});
  const std::string id = Submit(server, mesh, 64);
  const v1::Job requeued = testing::WatchUntil(server.bake(), id, testing::EndedOrRequeued);
  ASSERT_EQ(requeued.state(), v1::JOB_STATE_QUEUED) << requeued.DebugString();
  ASSERT_GE(requeued.attempt_history_size(), 1);
  const v1::JobAttempt& first = requeued.attempt_history(0);
  EXPECT_EQ(first.outcome(), v1::JobAttempt::OUTCOME_FAILED);
  EXPECT_NE(first.message().find("of its 4194304 bytes available (other files hold the rest)"), std::string::npos)
      << first.message();

  // The full worker is paused; a worker with room bakes the job.
  auto roomy = testing::StartWorker(server.address(), {"--name=roomy"});
  const v1::Job done = testing::WatchToEnd(server.bake(), id);
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
  EXPECT_EQ(done.worker_id().rfind("roomy-", 0), 0u) << done.worker_id();
  EXPECT_EQ(done.attempts(), 2u);
}

// The same full scratch, the worker alone: it used to lease the job back
// 3 ms after each failure and spend all three attempts itself. Now it
// leases nothing until its scratch could hold the job, so a worker started
// later bakes it, and the full one serves again once its space is freed.
TEST(ScratchFull, AWorkerShortOfScratchLeasesNothingUntilItHasRoom) {
  const fs::path mount_dir = testing::NewTempDir("scratch_wait");
  MOUNT_SCRATCH_OR_SKIP(mount_dir, "4m", tmpfs);
  const fs::path filler = mount_dir / "filler";
  std::ofstream(filler, std::ios::binary) << std::string(3 * kMiB, 'f');
  ServerProcess server(/*local_workers=*/0);  // default attempts and failure limit
  auto full = testing::StartWorker(server.address(), {"--name=full", "--scratch=" + (mount_dir / "scratch").string()});

  const std::string pad = RandomBytes(2 * kMiB, 5);
  v1::MeshInput mesh = testing::UploadGlb(server.assets(), testing::AssetsDir() / kBox);
  AddInput(server, mesh, pad, {"pad.bin"});
  const std::string id = Submit(server, mesh, 64);
  const v1::Job requeued = testing::WatchUntil(server.bake(), id, testing::EndedOrRequeued);
  ASSERT_EQ(requeued.state(), v1::JOB_STATE_QUEUED) << requeued.DebugString();

  auto roomy = testing::StartWorker(server.address(), {"--name=roomy"});
  const v1::Job done = testing::WatchToEnd(server.bake(), id);
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
  EXPECT_EQ(done.worker_id().rfind("roomy-", 0), 0u) << done.worker_id();
  EXPECT_EQ(done.attempts(), 2u);
  EXPECT_EQ(full->CountInLog("event=scratch_wait "), 1) << "the full worker did not say it stopped leasing";
  roomy.reset();
  if (HasFailure()) return;

  // Space back: the full worker leases again and bakes the same inputs.
  fs::remove(filler);
  ASSERT_TRUE(full->WaitForLog("outcome=room", 1, std::chrono::seconds(30))) << "the wait did not end";
  const v1::Job again = testing::WatchToEnd(server.bake(), Submit(server, mesh, 72));
  EXPECT_EQ(again.state(), v1::JOB_STATE_SUCCEEDED) << again.error().message();
  EXPECT_EQ(again.worker_id().rfind("full-", 0), 0u) << again.worker_id();
}

}  // namespace
}  // namespace impostor
