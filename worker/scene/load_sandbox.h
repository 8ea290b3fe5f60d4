// The isolated loader's process (isolated_load.h), kept for many loads.
//
// Forking a loader per file cost the isolation more than the load's own
// work: a fresh process faults in every page the decoders touch (a textured
// scene's PNG buffers are hundreds of MB), where a process that loaded
// before reuses its heap. A LoadSandbox is forked once, under the
// address-space limit, and loads one file per request: the worker sends the
// path, the limits and two memfds (scene_wire.h's bytes, texel_arena.h's
// texels) over a socket, and the sandbox replies with a one-line status.
//
// What a fresh process gave is kept where it matters: each load gets its
// own CPU-time budget (RLIMIT_CPU, raised by the load's seconds above what
// the process has used) and wall-clock deadline; a crash, a kill or a
// refusal for memory ends that sandbox only; a sandbox that reported any
// failure, or grew past kMaxIdleResidentBytes, or served kMaxLoads files is
// not used again. Nothing in it outlives a load but the heap's free memory:
// the scene itself lives in the worker's memfds.
//
// Thread-safety: one thread uses a sandbox at a time (isolated_load.cc
// keeps a pool under a mutex).
#ifndef IMPOSTOR_WORKER_SCENE_LOAD_SANDBOX_H_
#define IMPOSTOR_WORKER_SCENE_LOAD_SANDBOX_H_

#include <sys/types.h>

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "worker/scene/gltf_loader.h"

namespace impostor {

class LoadSandbox {
 public:
  // Files one sandbox loads before it is replaced.
  static constexpr int kMaxLoads = 64;
  // Resident memory a sandbox may keep between loads (its heap's free
  // pages, what makes the next load fast); above it, it is replaced.
  static constexpr uint64_t kMaxIdleResidentBytes = uint64_t{768} << 20;

  // Forks a sandbox whose RLIMIT_AS is the worker's address space now plus
  // `address_space_bytes`, capped at the worker's own hard limit.
  static absl::StatusOr<std::unique_ptr<LoadSandbox>> Start(uint64_t address_space_bytes);
  ~LoadSandbox();  // kills the process if it is still there

  // The memfds a load fills: -1 when only the status is wanted.
  struct HandOver {
    int scene_fd = -1;
    int texel_fd = -1;
  };
  struct Outcome {
    absl::Status status;
    // The sandbox may take another load.
    bool reusable = false;
    // The failure is the process's (a signal, memory, CPU), not the
    // loader's report on the file: worth one more try in a fresh sandbox
    // when this one had loaded other files before.
    bool process_failed = false;
  };
  Outcome Load(const std::filesystem::path& entry_file, const GltfLoadLimits& limits, int cpu_seconds,
               int wall_seconds, const std::atomic<bool>* cancelled, HandOver hand_over);

  uint64_t address_space_bytes() const { return address_space_bytes_; }
  int loads() const { return loads_; }

  // Sandboxes started by this process so far (tests see reuse with it).
  static int Started();

 private:
  LoadSandbox() = default;
  void Kill();

  pid_t pid_ = -1;
  int socket_ = -1;
  uint64_t address_space_bytes_ = 0;
  // The worker's own hard RLIMIT_AS when it, not address_space_bytes,
  // limits the sandbox (0 otherwise).
  uint64_t capped_at_ = 0;
  int loads_ = 0;
};

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_SCENE_LOAD_SANDBOX_H_
