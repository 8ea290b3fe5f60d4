// The other paths of an input blob that a job lists more than once
// (input_plan.h): each made to show the bytes already written at the first
// path, without writing them again, so that 4096 names of one upload take
// its bytes once on the worker's disk.
//
// A hard link where the filesystem allows it (the loader cannot tell it from
// a copy); where it does not (EXDEV, EPERM on a filesystem without links,
// EMLINK past its link limit) a symlink to the first path, which the
// loader's sandbox follows because it stays inside the input folder.
// Thread-safe; touches only the paths given.
#ifndef IMPOSTOR_WORKER_INPUT_LINKS_H_
#define IMPOSTOR_WORKER_INPUT_LINKS_H_

#include <filesystem>
#include <span>

#include "absl/status/status.h"

namespace impostor {

// Links each of `others` to `written` (an existing regular file). Their
// folders are made as for a downloaded input (MakeInputFolder). Errors:
// MakeInputFolder's; INVALID_ARGUMENT when one of `others` already exists
// (two inputs on one path, which ValidateMeshInput refuses); a full disk as
// ScratchWriteError; INTERNAL for any other failed link.
absl::Status LinkInputCopies(const std::filesystem::path& written, std::span<const std::filesystem::path> others);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_INPUT_LINKS_H_
