#include "worker/scratch_shortage.h"

#include <cstring>
#include <string>

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"
#include "common/disk_space.h"

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
  return absl::UnavailableError(absl::StrCat("the worker's scratch ", dir.string(), " ran out of space (", held,
                                             "; other files hold the rest): another worker may take it (",
                                             failure.message(), ")"));
}

}  // namespace impostor
