// Shared memory for decoded textures: the isolated loader's child
// (isolated_load.h) decodes every texture straight into a memfd, and the
// worker maps that memfd instead of receiving the texels through the scene
// bytes and copying them (a textured scene is 100 MB of texels; the copy on
// each side cost more than the isolation itself).
//
// The child installs its arena for the load (ScopedTexelArena); each
// TexelBuffer::CopyOf then grows the memfd and maps just the new region
// (page-aligned), so the child's RLIMIT_AS counts the texels as it counted
// their heap copy, and the worker later maps the whole file read-only.
//
// Thread-safety: Copy may be called from several threads at once (the
// loader decodes a load's textures side by side, image_predecode.h, each
// thread with the arena installed); the installed arena is per thread.
#ifndef IMPOSTOR_WORKER_SCENE_TEXEL_ARENA_H_
#define IMPOSTOR_WORKER_SCENE_TEXEL_ARENA_H_

#include <sys/types.h>

#include <cstdint>
#include <memory>
#include <mutex>
#include <span>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "worker/scene/texel_buffer.h"

namespace impostor {

class TexelArena {
 public:
  // Allocates in `fd` (a memfd the caller owns and keeps open), from its
  // current size on.
  explicit TexelArena(int fd) : fd_(fd) {}

  // `bytes` copied into the arena; std::bad_alloc when the memfd cannot
  // grow or the region cannot be mapped (the address-space limit).
  TexelBuffer Copy(std::span<const uint8_t> bytes);

 private:
  int fd_;
  std::mutex mu_;  // the region each Copy takes, and the memfd's growth
  uint64_t end_ ABSL_GUARDED_BY(mu_) = 0;  // page-aligned end of what is allocated
  off_t size_ ABSL_GUARDED_BY(mu_) = -1;   // the memfd's size, once looked at
};

// Installs `arena` for TexelBuffer::CopyOf on this thread while in scope.
class ScopedTexelArena {
 public:
  explicit ScopedTexelArena(TexelArena* arena);
  ~ScopedTexelArena();
  ScopedTexelArena(const ScopedTexelArena&) = delete;
  ScopedTexelArena& operator=(const ScopedTexelArena&) = delete;

 private:
  TexelArena* previous_;
};

// The arena installed on this thread, or null.
TexelArena* CurrentTexelArena();

// A memfd for a load's texels: one whose scene is gone (its pages kept, so
// the next load overwrites them instead of allocating), or a new one.
int TakeTexelFd();

// The texels a child left in the arena memfd `fd`, mapped read-only and
// whole: the spans of TexelBuffers made from it keep the mapping alive.
// Takes `fd`: when the mapping goes, the memfd is kept for TakeTexelFd (or
// closed). Bytes past what the load wrote are an earlier load's, never
// referenced.
struct MappedTexels {
  std::shared_ptr<const void> owner;
  std::span<const uint8_t> bytes;
};
absl::StatusOr<MappedTexels> MapTexelArena(int fd);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_SCENE_TEXEL_ARENA_H_
