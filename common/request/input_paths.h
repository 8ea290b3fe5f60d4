// Where a MeshInput's files land on a worker's disk, and the check that no
// two of them can land on the same place. The worker writes the entry as
// input/<file name of entry.path> and every other file as input/<path>, so
// two inputs collide when
//  * they are equal, or equal but for ASCII case (one file on a
//    case-insensitive file system, where a worker or the client may run);
//  * one names a file that another needs as a directory ("a" and
//    "a/b.png"; before this check the worker's create_directories threw and
//    took the process down on every retry, issue 23);
//  * a file has the entry's on-disk name (it would overwrite the entry).
// Spellings that differ but name the same path ("./a", "a/", "a//b",
// "a/../b") never get here: ValidateRelativePath refuses empty, "." and
// ".." components. Unicode normalisation (NFC vs NFD) is not folded.
// Pure functions; thread-safe.
#ifndef IMPOSTOR_COMMON_REQUEST_INPUT_PATHS_H_
#define IMPOSTOR_COMMON_REQUEST_INPUT_PATHS_H_

#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "impostor/v1/types.pb.h"

namespace impostor {

// The path the entry file gets in the worker's input directory.
std::string EntryDiskPath(const v1::MeshInput& mesh);

// OK if no two inputs of `mesh` collide as above; INVALID_ARGUMENT naming
// both fields and both paths otherwise. Paths must each have passed
// ValidateRelativePath.
absl::Status CheckInputPathsDisjoint(const v1::MeshInput& mesh);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_REQUEST_INPUT_PATHS_H_
