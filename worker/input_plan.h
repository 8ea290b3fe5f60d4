// Where a job's input blobs go in its scratch folder, one download per
// distinct blob: a request may list one uploaded blob under many paths (up
// to 4096, each a different file name), and writing it once per path let a
// small upload fill a worker's disk. The first path of each blob gets the
// bytes; the others are linked to it (input_links.h).
//
// And what the plan costs on disk, so that a job that cannot fit is refused
// before its first byte is written (scratch_space.h).
//
// Pure functions over the request; thread-safe. The paths must have passed
// ValidateMeshInput (relative, no "..", no two landing on one place).
#ifndef IMPOSTOR_WORKER_INPUT_PLAN_H_
#define IMPOSTOR_WORKER_INPUT_PLAN_H_

#include <cstdint>
#include <filesystem>
#include <vector>

#include "impostor/v1/types.pb.h"

namespace impostor {

// One distinct blob (hash and size) and every path the request lists it
// under, in request order: the entry first, then mesh.files.
struct InputBlob {
  v1::Digest digest;
  std::vector<std::filesystem::path> paths;  // never empty; paths[0] gets the bytes
};

struct InputPlan {
  std::vector<InputBlob> blobs;      // in order of first mention
  std::filesystem::path entry_path;  // input_dir / the entry's file name
  int path_count = 0;                // entry + files
};

// The inputs of `mesh` under `input_dir` (the entry as its file name, every
// other file as its relative path), grouped by digest. Two digests are one
// blob only when hash and size both match.
InputPlan PlanInputs(const v1::MeshInput& mesh, const std::filesystem::path& input_dir);

// What writing a plan takes from a filesystem.
struct ScratchDemand {
  // Each distinct blob rounded up to whole blocks, plus the folders
  // (`input_dir` included): the larger of one block each and all their
  // directory entries (8 bytes + the name, as ext4 stores them) in whole
  // blocks, a lower bound of what ext4 takes for them. Folders cost no
  // blocks on tmpfs: there this overestimates by a block a folder.
  // Saturates at INT64_MAX (sizes come from the request).
  int64_t bytes = 0;
  // One per distinct blob and one per folder (links share their blob's).
  int64_t inodes = 0;
  int blob_count = 0;  // distinct blobs
  int path_count = 0;  // paths they are listed under
};

// `block_bytes` > 0: the filesystem's allocation unit (statvfs f_frsize).
ScratchDemand EstimateScratchDemand(const InputPlan& plan, const std::filesystem::path& input_dir,
                                    int64_t block_bytes);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_INPUT_PLAN_H_
