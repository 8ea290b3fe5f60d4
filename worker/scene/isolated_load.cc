#include "worker/scene/isolated_load.h"

#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <spdlog/spdlog.h>

#include <chrono>
#include <cstring>
#include <memory>
#include <mutex>
#include <vector>

#include "absl/strings/str_cat.h"
#include "worker/scene/load_sandbox.h"
#include "worker/scene/scene_wire.h"
#include "worker/scene/texel_arena.h"

namespace impostor {
namespace {

using Clock = std::chrono::steady_clock;
using HandOver = LoadSandbox::HandOver;

// Sandboxes waiting for the next load: two cover a worker baking with a
// second job's load overlapping. Never destroyed: at exit the worker's ends
// of their sockets close and they leave by themselves.
constexpr size_t kMaxIdleSandboxes = 2;

struct SandboxPool {
  std::mutex mu;
  std::vector<std::unique_ptr<LoadSandbox>> idle;  // most recently used last
};

SandboxPool& Pool() {
  static SandboxPool* pool = new SandboxPool();
  return *pool;
}

std::unique_ptr<LoadSandbox> TakeIdle(uint64_t address_space_bytes) {
  SandboxPool& pool = Pool();
  std::lock_guard<std::mutex> lock(pool.mu);
  for (auto it = pool.idle.rbegin(); it != pool.idle.rend(); ++it) {
    if ((*it)->address_space_bytes() != address_space_bytes) continue;
    std::unique_ptr<LoadSandbox> sandbox = std::move(*it);
    pool.idle.erase(std::next(it).base());
    return sandbox;
  }
  return nullptr;
}

void GiveBack(std::unique_ptr<LoadSandbox> sandbox) {
  std::unique_ptr<LoadSandbox> dropped;  // killed outside the lock
  SandboxPool& pool = Pool();
  std::lock_guard<std::mutex> lock(pool.mu);
  pool.idle.push_back(std::move(sandbox));
  if (pool.idle.size() > kMaxIdleSandboxes) {
    dropped = std::move(pool.idle.front());
    pool.idle.erase(pool.idle.begin());
  }
}

// Empties the memfds a failed try may have half filled.
void Reset(HandOver hand_over) {
  for (int fd : {hand_over.scene_fd, hand_over.texel_fd}) {
    if (fd < 0) continue;
    (void)::ftruncate(fd, 0);
    (void)::lseek(fd, 0, SEEK_SET);
  }
}

// Loads in a sandbox (a reused one when there is one) and returns how that
// ended. A process failure (a signal, memory, CPU) in a sandbox that had
// loaded other files is tried once more in a fresh one, so that nothing an
// earlier file left behind is blamed on this one.
absl::Status RunIsolated(const std::filesystem::path& entry_file, const GltfLoadLimits& limits,
                         const LoadIsolation& isolation, const std::atomic<bool>* cancelled, HandOver hand_over) {
  if (isolation.address_space_bytes < (uint64_t{64} << 20) || isolation.cpu_seconds < 1 ||
      isolation.cpu_seconds > 86400 || isolation.wall_seconds < 1 || isolation.wall_seconds > 86400) {
    return absl::InvalidArgumentError(absl::StrCat(
        "LoadIsolation out of range: address_space_bytes ", isolation.address_space_bytes,
        ", cpu_seconds ", isolation.cpu_seconds, ", wall_seconds ", isolation.wall_seconds));
  }
  if (cancelled && *cancelled) return absl::CancelledError("cancelled before loading");
  const auto start = Clock::now();
  for (int attempt = 0;; ++attempt) {
    std::unique_ptr<LoadSandbox> sandbox = attempt == 0 ? TakeIdle(isolation.address_space_bytes) : nullptr;
    if (sandbox == nullptr) {
      absl::StatusOr<std::unique_ptr<LoadSandbox>> started = LoadSandbox::Start(isolation.address_space_bytes);
      if (!started.ok()) return started.status();
      sandbox = std::move(*started);
    }
    const int earlier_loads = sandbox->loads();
    LoadSandbox::Outcome outcome = sandbox->Load(entry_file, limits, isolation.cpu_seconds, isolation.wall_seconds,
                                                 cancelled, hand_over);
    if (outcome.reusable) GiveBack(std::move(sandbox));
    if (outcome.process_failed && earlier_loads > 0 && attempt == 0) {
      spdlog::debug("event=isolated_load_retry file={} after_loads={} status=\"{}\"", entry_file.filename().string(),
                    earlier_loads, outcome.status.ToString());
      Reset(hand_over);
      continue;
    }
    spdlog::debug("event=isolated_load file={} seconds={:.3f} reused={} status=\"{}\"", entry_file.filename().string(),
                  std::chrono::duration<double>(Clock::now() - start).count(), earlier_loads > 0,
                  outcome.status.ToString());
    return outcome.status;
  }
}

// The scene the child handed over, checked (scene_wire.h); its textures
// are views of the mapped texel memfd, which this takes.
absl::StatusOr<Scene> ReadScene(HandOver hand_over) {
  absl::StatusOr<MappedTexels> texels = MapTexelArena(hand_over.texel_fd);
  if (!texels.ok()) return texels.status();
  struct stat st {};
  if (::fstat(hand_over.scene_fd, &st) != 0) return absl::InternalError(absl::StrCat("fstat: ", std::strerror(errno)));
  if (st.st_size <= 0) return absl::DataLossError("the isolated loader handed over no scene");
  const size_t size = static_cast<size_t>(st.st_size);
  void* mapped = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE | MAP_POPULATE, hand_over.scene_fd, 0);
  if (mapped == MAP_FAILED) return absl::InternalError(absl::StrCat("mmap: ", std::strerror(errno)));
  absl::StatusOr<Scene> scene = DecodeScene(std::span(static_cast<const uint8_t*>(mapped), size), &*texels);
  ::munmap(mapped, size);
  return scene;
}

}  // namespace

absl::Status CheckLoadInChild(const std::filesystem::path& entry_file, const GltfLoadLimits& limits,
                              const LoadIsolation& isolation, const std::atomic<bool>* cancelled) {
  if (!isolation.enabled) return absl::OkStatus();
  return RunIsolated(entry_file, limits, isolation, cancelled, HandOver{});
}

absl::StatusOr<Scene> LoadSceneInChild(const std::filesystem::path& entry_file, const GltfLoadLimits& limits,
                                       const LoadIsolation& isolation, const std::atomic<bool>* cancelled) {
  if (!isolation.enabled) return LoadGltfScene(entry_file, limits);
  // Anonymous shared memory the sandbox fills; freed with the last
  // reference (the texels' with the scene's last texture).
  HandOver hand_over;
  hand_over.scene_fd = ::memfd_create("impostor-scene", MFD_CLOEXEC);
  hand_over.texel_fd = TakeTexelFd();
  absl::StatusOr<Scene> scene = absl::InternalError("the isolated loader handed over no scene");
  if (hand_over.scene_fd < 0 || hand_over.texel_fd < 0) {
    scene = absl::InternalError(absl::StrCat("memfd_create: ", std::strerror(errno)));
  } else if (absl::Status loaded = RunIsolated(entry_file, limits, isolation, cancelled, hand_over); !loaded.ok()) {
    scene = loaded;
  } else {
    scene = ReadScene(hand_over);
    hand_over.texel_fd = -1;  // the scene's textures hold it now
  }
  if (hand_over.scene_fd >= 0) ::close(hand_over.scene_fd);
  if (hand_over.texel_fd >= 0) ::close(hand_over.texel_fd);
  return scene;
}

}  // namespace impostor
