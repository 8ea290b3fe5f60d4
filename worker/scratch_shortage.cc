#include "worker/scratch_shortage.h"

#include <cstring>
#include <string>

#include <spdlog/spdlog.h>

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"
#include "common/util/disk_space.h"

namespace impostor {
namespace {

// The payload that marks a write refused for want of space: the code alone
// cannot say it (RESOURCE_EXHAUSTED is also a mesh over the load limits).
constexpr char kScratchFullPayload[] = "type.impostor.dev/worker.ScratchFull";

// Less free than this after an unexplained bake failure: the scratch was
// full. A failed write fills the disk to its last block, and every bake
// output is larger than this margin.
constexpr int64_t kFullMarginBytes = 1 << 20;

bool LooksFull(const ScratchSpace& now) {
  return now.available_bytes < kFullMarginBytes || (now.capacity_inodes > 0 && now.available_inodes == 0);
}

// The job's share of what is in use is at least 15/16.
bool HoldsNearlyAll(int64_t job, int64_t in_use) { return in_use <= 0 || job >= in_use - in_use / 16; }

}  // namespace

absl::Status ScratchWriteError(std::string_view what, const std::filesystem::path& path, int error_number) {
  const std::string message =
      absl::StrCat("cannot ", std::string(what), " ", path.string(), ": ", std::strerror(error_number));
  if (!IsDiskFull(error_number)) return absl::InternalError(message);
  absl::Status status = absl::ResourceExhaustedError(message);
  status.SetPayload(kScratchFullPayload, absl::Cord());
  return status;
}

bool IsScratchFull(const absl::Status& status) { return status.GetPayload(kScratchFullPayload).has_value(); }

absl::Status AttributeScratchShortage(const absl::Status& failure, const ScratchFacts& facts,
                                      const std::filesystem::path& dir) {
  const bool unexplained = failure.code() == absl::StatusCode::kInternal || failure.code() == absl::StatusCode::kUnknown;
  if (!IsScratchFull(failure) && !(unexplained && LooksFull(facts.now))) return failure;
  const ScratchSpace& now = facts.now;
  const int64_t bytes_in_use = now.capacity_bytes - now.available_bytes;
  const bool out_of_inodes = now.capacity_inodes > 0 && now.available_inodes == 0;
  const bool jobs_fault = out_of_inodes ? HoldsNearlyAll(facts.job.inodes, now.capacity_inodes)
                                        : HoldsNearlyAll(facts.job.bytes, bytes_in_use);
  const std::string need =
      facts.inputs_need >= 0 ? absl::StrCat("; its inputs need ", facts.inputs_need, " bytes") : std::string();
  const std::string held = absl::StrCat(
      "the job's folder held ", facts.job.bytes, " bytes",
      out_of_inodes ? absl::StrCat(" and ", facts.job.inodes, " of its ", now.capacity_inodes, " inodes") : "",
      need, "; ", now.available_bytes, " of ", now.capacity_bytes, " bytes available now, ",
      facts.at_start.available_bytes, " when the job started");
  if (jobs_fault) {
    return absl::ResourceExhaustedError(
        absl::StrCat("the job ran out of the worker's scratch ", dir.string(), " by itself (", held,
                     "): it needs more than this worker holds; send smaller inputs or ask for smaller outputs, or "
                     "give the workers a larger --scratch (",
                     failure.message(), ")"));
  }
  return ShortOnThisWorker(absl::StrCat("the worker's scratch ", dir.string(), " ran out of space (", held,
                                             "; other files hold the rest): another worker may take it (",
                                             failure.message(), ")"));
}

int64_t BytesToLeaseAgain(const ScratchFacts& facts) {
  if (facts.inputs_need > facts.at_start.available_bytes) return facts.inputs_need;
  return facts.at_start.available_bytes + kFullMarginBytes;
}

bool WaitForScratchRoom(const std::filesystem::path& dir, int64_t need_bytes, std::chrono::seconds budget,
                        const std::function<bool(std::chrono::milliseconds)>& pause) {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  auto available = [&dir] {
    const absl::StatusOr<ScratchSpace> space = MeasureScratch(dir);
    return space.ok() ? space->available_bytes : int64_t{-1};
  };
  int64_t now_available = available();
  if (now_available >= need_bytes) return true;
  spdlog::warn("event=scratch_wait dir=\"{}\" need_bytes={} available_bytes={} max_wait_s={} action=no_lease",
               dir.string(), need_bytes, now_available, budget.count());
  auto backoff = std::chrono::milliseconds(200);
  bool stopped = false;
  while (now_available < need_bytes && Clock::now() - start < budget) {
    if (!pause(backoff)) {
      stopped = true;
      break;
    }
    backoff = std::min(backoff * 2, std::chrono::milliseconds(5000));
    now_available = available();
  }
  const bool room = now_available >= need_bytes;
  spdlog::info("event=scratch_wait_end dir=\"{}\" need_bytes={} available_bytes={} waited_s={:.1f} outcome={}",
               dir.string(), need_bytes, now_available,
               std::chrono::duration<double>(Clock::now() - start).count(),
               room ? "room" : (stopped ? "stopping" : "budget_spent_leasing_anyway"));
  return room;
}

}  // namespace impostor
