// A job that ran out of scratch space while it ran: named, and ended as the
// job's fault or the worker's (see scratch_space.h for the same split
// before the job starts, and for why it matters to the server).
//
// The check before the download (CheckInputsFit) makes a shortfall during
// a job rare: the inputs' estimate was short, something else filled the
// disk meanwhile, or the bake's outputs did not fit. Before this file such
// a failure was an unnamed, retryable INTERNAL ("cannot write ..."), so
// three hostile jobs paused a healthy worker. Now:
//  * the job's fault when its own folder held at least 15/16 of what was in
//    use on the scratch when it filled (the rest: filesystem metadata and a
//    small neighbour): it would not fit on an empty scratch of this size
//    either. RESOURCE_EXHAUSTED, final: no retry, no pause.
//  * otherwise the worker's state: other files hold enough of the scratch
//    that the job might fit without them. UNAVAILABLE (ShortOnThisWorker),
//    retryable: another worker takes the job. This worker then leases
//    nothing until its scratch has room for that job again
//    (WaitForScratchRoom): leasing at once took the same job back 3 ms
//    after each failure and spent all its attempts on the full worker.
// Thread-safe.
#ifndef IMPOSTOR_WORKER_SCRATCH_SHORTAGE_H_
#define IMPOSTOR_WORKER_SCRATCH_SHORTAGE_H_

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string_view>

#include "absl/status/status.h"
#include "worker/scratch_space.h"

namespace impostor {

// The error of a scratch write (`what`: "write", "create", "link", ...) that
// failed with `error_number`. ENOSPC and EDQUOT give a status marked as a
// full scratch (IsScratchFull), anything else INTERNAL; both name the path
// and the cause.
absl::Status ScratchWriteError(std::string_view what, const std::filesystem::path& path, int error_number);

// True for a status from ScratchWriteError for a full disk or quota.
bool IsScratchFull(const absl::Status& status);

// What the scratch looked like around a failed job.
struct ScratchFacts {
  ScratchSpace at_start;     // when the job's folder was made
  ScratchSpace now;          // after the failure
  ScratchHeld job;           // the job's folder, after the failure
  int64_t inputs_need = -1;  // bytes the inputs need on disk; -1 unknown
};

// `failure` unchanged unless the scratch ran out: a status marked by
// ScratchWriteError, or an INTERNAL or UNKNOWN one (a bake's output writer
// knows no errno) while under 1 MiB or no inode is left. Then
// RESOURCE_EXHAUSTED or UNAVAILABLE as above, naming `dir`, the bytes the
// job held, the bytes available and in all (and the inputs' need when
// known), ending with `failure`'s message.
absl::Status AttributeScratchShortage(const absl::Status& failure, const ScratchFacts& facts,
                                      const std::filesystem::path& dir);

// The bytes the scratch must have available before a worker whose job
// failed with ShortOnThisWorker leases again: the inputs' need when they
// did not fit what was free; else more than the job found available when
// it started (it used all of that and ran out), by a 1 MiB margin.
int64_t BytesToLeaseAgain(const ScratchFacts& facts);

// Waits until `dir`'s filesystem has `need_bytes` available, re-measuring
// with backoff (0.2 s doubling to 5 s), for at most `budget`. `pause(d)`
// waits d and returns false when the worker stops (the wait ends at once).
// Logs one event line as the wait begins and one as it ends. True when the
// room is there.
bool WaitForScratchRoom(const std::filesystem::path& dir, int64_t need_bytes, std::chrono::seconds budget,
                        const std::function<bool(std::chrono::milliseconds)>& pause);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_SCRATCH_SHORTAGE_H_
