// The worker's scratch filesystem (--scratch): how much it holds, how much
// is free, how much one job's folder takes, and whether a job's inputs fit
// before the first byte is written.
//
// Whose fault a shortfall is decides how the job ends (the server requeues
// a retryable failure and counts it against the worker; a final one fails
// the job at once and counts against no one, bake_scheduler.h):
//  * inputs that need more than the scratch's whole capacity are the job's
//    fault: RESOURCE_EXHAUSTED, final. Every worker of a farm is set up
//    alike, so a retry would fail the same way elsewhere, and each retryable
//    failure would count towards pausing a healthy worker: three such jobs
//    took a worker out of service for 5 minutes.
//  * inputs that fit the capacity but not what is free now are the worker's
//    state, not the job's (its previous job's folder is gone; something
//    else fills the disk): UNAVAILABLE, retryable. The job goes to another
//    worker, and a worker whose scratch stays full is paused, as it should.
// Pure functions apart from MeasureScratch and BytesHeldUnder; thread-safe.
#ifndef IMPOSTOR_WORKER_SCRATCH_SPACE_H_
#define IMPOSTOR_WORKER_SCRATCH_SPACE_H_

#include <cstdint>
#include <filesystem>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "worker/input_plan.h"

namespace impostor {

// UNAVAILABLE with `message`, marked as this worker's scratch being too full
// for a job that would fit it empty (the worker's state, not the job's). The
// worker leases nothing more until the scratch has room again
// (WaitForScratchRoom, scratch_shortage.h), else it takes the same job back
// within milliseconds and spends all its attempts itself.
absl::Status ShortOnThisWorker(const std::string& message);
// True for a status from ShortOnThisWorker.
bool IsShortOnThisWorker(const absl::Status& status);

// One look at a filesystem, as an unprivileged writer sees it (root's
// reserve left out: the worker need not run as root).
struct ScratchSpace {
  int64_t capacity_bytes = 0;
  int64_t available_bytes = 0;
  int64_t block_bytes = 4096;  // allocation unit (f_frsize)
  // 0 when the filesystem sets no inode limit (btrfs): not checked.
  int64_t capacity_inodes = 0;
  int64_t available_inodes = 0;
};

// The filesystem holding `dir`. INTERNAL naming the folder when statvfs
// fails (the scratch folder is gone).
absl::StatusOr<ScratchSpace> MeasureScratch(const std::filesystem::path& dir);

// OK when `demand` fits what is available; else, naming the bytes (or
// inodes) needed, available and in all, and `dir`: RESOURCE_EXHAUSTED when
// it exceeds the capacity, ShortOnThisWorker when only what is free now.
absl::Status CheckInputsFit(const ScratchDemand& demand, const ScratchSpace& space,
                            const std::filesystem::path& dir);

// What `dir` and everything under it take on disk: allocated bytes and
// inodes, each hard-linked file counted once. Unreadable entries count 0.
struct ScratchHeld {
  int64_t bytes = 0;
  int64_t inodes = 0;
};
ScratchHeld BytesHeldUnder(const std::filesystem::path& dir);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_SCRATCH_SPACE_H_
