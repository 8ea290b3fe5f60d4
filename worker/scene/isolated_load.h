// Loads an untrusted glTF in a child process, under an address-space and a
// CPU-time limit (setrlimit), instead of in the worker. The child is kept
// between loads and replaced after any refusal (load_sandbox.h).
//
// The load budget (load_budget.h) refuses what the file declares; this is
// the second line, for whatever slips past it (a decoder or parser bug, a
// cost the budget does not model): the bomb goes off in a forked child,
// which dies or fails alone, and the worker reports a non-retryable failure
// and takes the next job. The child does the whole load (parse, budget,
// build, texture decode) and reports only its status; loading is
// deterministic, so a file that loads in the child under the limits loads
// the same way in the worker afterwards. LoadSceneInChild also hands the
// child's scene back through shared memory (scene_wire.h checks every byte
// of it), so the worker does not decode the file a second time: the child
// decodes textures straight into a memfd that the worker maps
// (texel_arena.h), so the texels are never copied;
// CheckLoadInChild only reports, for a caller that loads the file its own
// way (bench/isolated_load_bench and bench/e2e_bench.sh measure the cost).
//
// Thread-safety: reentrant. Safe to call from a multithreaded process: the
// child only runs the loader (no gRPC, logging switched off) and leaves
// with _exit.
#ifndef IMPOSTOR_WORKER_SCENE_ISOLATED_LOAD_H_
#define IMPOSTOR_WORKER_SCENE_ISOLATED_LOAD_H_

#include <atomic>
#include <cstdint>
#include <filesystem>

#include "absl/status/status.h"
#include "worker/scene/gltf_loader.h"

namespace impostor {

struct LoadIsolation {
  // Off: CheckLoadInChild returns OK without loading (the caller's own load
  // is then the only one). Default on.
  bool enabled = true;
  // Address space the child may add to what it inherits from the worker,
  // bytes (RLIMIT_AS = the worker's size at fork + this). Default 8 GiB,
  // above GltfLoadLimits::max_load_bytes' default of 6 GiB; >= 64 MiB.
  uint64_t address_space_bytes = uint64_t{8} << 30;
  // CPU seconds the child may use (RLIMIT_CPU). Default 300; range 1..86400.
  int cpu_seconds = 300;
  // Wall-clock seconds before the child is killed (a child blocked without
  // using CPU). Default 600; range 1..86400.
  int wall_seconds = 600;
};

// Loads `entry_file` with LoadGltfScene(entry_file, limits) in a forked
// child and returns how that ended:
//   OK                 the file loads within `limits` and the rlimits;
//   what LoadGltfScene returned, when it failed in the child;
//   RESOURCE_EXHAUSTED the child ran out of address space, CPU time or wall
//                      time (naming which and the limit);
//   INVALID_ARGUMENT   the child crashed (naming the signal): the loader
//                      failed on this file, and will again;
//   CANCELLED          `cancelled` became true (the child is killed);
//   INTERNAL           fork or pipe failed.
absl::Status CheckLoadInChild(const std::filesystem::path& entry_file, const GltfLoadLimits& limits,
                              const LoadIsolation& isolation,
                              const std::atomic<bool>* cancelled = nullptr);

// The same, returning the scene the child loaded: statuses as above, plus
// DATA_LOSS when the child's scene fails a check (scene_wire.h). With
// isolation off, LoadGltfScene(entry_file, limits) in this process.
absl::StatusOr<Scene> LoadSceneInChild(const std::filesystem::path& entry_file, const GltfLoadLimits& limits,
                                       const LoadIsolation& isolation,
                                       const std::atomic<bool>* cancelled = nullptr);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_SCENE_ISOLATED_LOAD_H_
