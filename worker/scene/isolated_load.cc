#include "worker/scene/isolated_load.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <new>
#include <optional>
#include <string>

#include "absl/strings/str_cat.h"
#include "worker/scene/scene_wire.h"
#include "worker/scene/texel_arena.h"

namespace impostor {
namespace {

using Clock = std::chrono::steady_clock;

// Most of a child's report that is read: a status code and a one-line
// message (the loader caps its messages well below this).
constexpr size_t kMaxReportBytes = 8192;

// The worker's address space now, bytes (first field of /proc/self/statm).
uint64_t CurrentAddressSpace() {
  std::ifstream statm("/proc/self/statm");
  uint64_t pages = 0;
  statm >> pages;
  return pages * static_cast<uint64_t>(::sysconf(_SC_PAGESIZE));
}

bool WriteAll(int fd, std::string_view bytes) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += static_cast<size_t>(n);
  }
  return true;
}

// The child's report: its length as 4 native-order bytes, then
// "<code> <message>". The length lets the worker act on the report as soon
// as it is complete, while the child's exit still tears down its address
// space (tens of milliseconds for a textured scene), instead of at EOF.
void WriteReport(int report_fd, const std::string& report) {
  const uint32_t size = static_cast<uint32_t>(std::min(report.size(), kMaxReportBytes));
  WriteAll(report_fd, std::string_view(reinterpret_cast<const char*>(&size), sizeof(size)));
  WriteAll(report_fd, std::string_view(report.data(), size));
}

// Where the child puts the scene it loaded: its bytes (scene_wire.h) into
// `scene_fd` and its textures' texels into `texel_fd` (texel_arena.h), two
// memfds; -1 when only the status is wanted.
struct HandOver {
  int scene_fd = -1;
  int texel_fd = -1;
};

// The child: limits, load, the scene into `hand_over`, report
// "<code> <message>", leave.
[[noreturn]] void RunChild(int report_fd, HandOver hand_over, const std::filesystem::path& entry_file,
                           const GltfLoadLimits& limits, uint64_t address_space, int cpu_seconds) {
  // No locks: another thread of the parent may have held the logger's.
  if (spdlog::logger* logger = spdlog::default_logger_raw()) logger->set_level(spdlog::level::off);
  const rlimit as{address_space, address_space};
  const rlimit cpu{static_cast<rlim_t>(cpu_seconds), static_cast<rlim_t>(cpu_seconds) + 1};
  if (::setrlimit(RLIMIT_AS, &as) != 0 || ::setrlimit(RLIMIT_CPU, &cpu) != 0) {
    // Said, not just exited: "status 3 without a report" told nobody why.
    WriteReport(report_fd, absl::StrCat(static_cast<int>(absl::StatusCode::kInternal),
                                        " cannot set the loader's limits: ", std::strerror(errno)));
    ::_exit(3);
  }
  // No core files for a bomb.
  const rlimit no_core{0, 0};
  ::setrlimit(RLIMIT_CORE, &no_core);
  try {
    // Textures are decoded straight into shared memory, which the worker
    // maps rather than copies.
    std::optional<TexelArena> arena;
    std::optional<ScopedTexelArena> use_arena;
    if (hand_over.texel_fd >= 0) use_arena.emplace(&arena.emplace(hand_over.texel_fd));
    const absl::StatusOr<Scene> scene = LoadGltfScene(entry_file, limits);
    std::string report = absl::StrCat(static_cast<int>(scene.status().code()), " ", scene.status().message());
    if (scene.ok() && hand_over.scene_fd >= 0) {
      bool written = true;
      EncodeScene(
          *scene, [&](std::string_view bytes) { written = written && WriteAll(hand_over.scene_fd, bytes); },
          arena ? &*arena : nullptr);
      if (!written) {
        report = absl::StrCat(static_cast<int>(absl::StatusCode::kInternal),
                              " could not hand the loaded scene to the worker: ", std::strerror(errno));
      }
    }
    WriteReport(report_fd, report);
    ::_exit(0);  // the scene is not freed: the exit tears the whole space down at once
  } catch (const std::bad_alloc&) {
    WriteReport(report_fd, absl::StrCat(static_cast<int>(absl::StatusCode::kResourceExhausted), " out of memory"));
  } catch (...) {
    WriteReport(report_fd, absl::StrCat(static_cast<int>(absl::StatusCode::kInvalidArgument), " the loader threw"));
  }
  ::_exit(0);
}

std::string SignalName(int sig) {
  const char* name = ::sigabbrev_np(sig);
  return name ? absl::StrCat("SIG", name) : absl::StrCat("signal ", sig);
}

// The scene the child handed over, checked (scene_wire.h); its textures
// are views of the mapped texel memfd.
absl::StatusOr<Scene> ReadScene(HandOver hand_over) {
  absl::StatusOr<MappedTexels> texels = MapTexelArena(hand_over.texel_fd);
  if (!texels.ok()) return texels.status();
  const int scene_fd = hand_over.scene_fd;
  struct stat st {};
  if (::fstat(scene_fd, &st) != 0) return absl::InternalError(absl::StrCat("fstat: ", std::strerror(errno)));
  if (st.st_size <= 0) return absl::DataLossError("the isolated loader handed over no scene");
  const size_t size = static_cast<size_t>(st.st_size);
  void* mapped = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE | MAP_POPULATE, scene_fd, 0);
  if (mapped == MAP_FAILED) return absl::InternalError(absl::StrCat("mmap: ", std::strerror(errno)));
  absl::StatusOr<Scene> scene = DecodeScene(std::span(static_cast<const uint8_t*>(mapped), size), &*texels);
  ::munmap(mapped, size);
  return scene;
}

// Forks the child and returns how it ended; the child hands its scene over
// through `hand_over` (when its fds are >= 0).
absl::Status RunIsolated(const std::filesystem::path& entry_file, const GltfLoadLimits& limits,
                         const LoadIsolation& isolation, const std::atomic<bool>* cancelled, HandOver hand_over) {
  if (isolation.address_space_bytes < (uint64_t{64} << 20) || isolation.cpu_seconds < 1 ||
      isolation.cpu_seconds > 86400 || isolation.wall_seconds < 1 || isolation.wall_seconds > 86400) {
    return absl::InvalidArgumentError(absl::StrCat(
        "LoadIsolation out of range: address_space_bytes ", isolation.address_space_bytes,
        ", cpu_seconds ", isolation.cpu_seconds, ", wall_seconds ", isolation.wall_seconds));
  }
  if (cancelled && *cancelled) return absl::CancelledError("cancelled before loading");
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) {
    return absl::InternalError(absl::StrCat("pipe: ", std::strerror(errno)));
  }
  // The child can lower its limits but never raise them past the worker's
  // own hard RLIMIT_AS (a container or `ulimit -v`): asking for more failed
  // setrlimit and every load with it. Within that limit the loader gets what
  // is left, and a load that needs more is the usual out-of-memory refusal.
  uint64_t address_space = CurrentAddressSpace() + isolation.address_space_bytes;
  rlimit worker_as{};
  const bool capped = ::getrlimit(RLIMIT_AS, &worker_as) == 0 && worker_as.rlim_max != RLIM_INFINITY &&
                      worker_as.rlim_max < address_space;
  if (capped) address_space = worker_as.rlim_max;
  const auto start = Clock::now();
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    return absl::InternalError(absl::StrCat("fork: ", std::strerror(errno)));
  }
  if (pid == 0) {
    ::close(fds[0]);
    RunChild(fds[1], hand_over, entry_file, limits, address_space, isolation.cpu_seconds);
  }
  ::close(fds[1]);

  // Read the report until it is complete (or EOF), watching for
  // cancellation and the wall limit.
  std::string report;
  uint32_t report_size = 0;
  auto complete = [&] {
    if (report.size() < sizeof(report_size)) return false;
    std::memcpy(&report_size, report.data(), sizeof(report_size));
    return report_size <= kMaxReportBytes && report.size() >= sizeof(report_size) + report_size;
  };
  const auto deadline = start + std::chrono::seconds(isolation.wall_seconds);
  absl::Status stopped;
  while (!complete()) {
    if (cancelled && *cancelled) {
      stopped = absl::CancelledError("cancelled while loading");
      break;
    }
    if (Clock::now() > deadline) {
      stopped = absl::ResourceExhaustedError(
          absl::StrCat("loading took longer than ", isolation.wall_seconds, " s (LoadIsolation::wall_seconds)"));
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    if (::poll(&p, 1, 50) <= 0) continue;  // timeout (or EINTR): check again
    char buf[1024];
    const ssize_t n = ::read(fds[0], buf, sizeof(buf));
    if (n > 0) {
      if (report.size() < kMaxReportBytes + sizeof(report_size)) report.append(buf, static_cast<size_t>(n));
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    break;  // EOF: the child has exited without a whole report
  }
  ::close(fds[0]);
  const bool reported = stopped.ok() && complete();
  int code = -1;
  std::string message;
  if (reported) {
    const std::string text = report.substr(sizeof(report_size), report_size);
    const size_t space = text.find(' ');
    code = std::atoi(text.substr(0, space).c_str());
    message = space == std::string::npos ? "" : text.substr(space + 1);
  }
  // Nothing the child does after its report (or a stop) is of use: a
  // compromised child must not keep the worker waiting in waitpid, nor
  // touch the memfds once the worker reads them (it is gone by then).
  if (reported || !stopped.ok()) ::kill(pid, SIGKILL);
  int wstatus = 0;
  while (::waitpid(pid, &wstatus, 0) < 0 && errno == EINTR) {
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  spdlog::debug("event=isolated_load file={} seconds={:.3f} status={}", entry_file.filename().string(),
                seconds, reported ? absl::StrCat("reported ", code)
                         : WIFEXITED(wstatus) ? absl::StrCat("exit ", WEXITSTATUS(wstatus))
                                              : SignalName(WTERMSIG(wstatus)));
  if (!stopped.ok()) return stopped;

  if (!reported && WIFSIGNALED(wstatus)) {
    const int sig = WTERMSIG(wstatus);
    if (sig == SIGXCPU || sig == SIGKILL) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "loading was stopped by ", SignalName(sig), " after ", isolation.cpu_seconds,
          " CPU seconds at most (LoadIsolation::cpu_seconds) or by the kernel for memory"));
    }
    return absl::InvalidArgumentError(absl::StrCat(
        "the glTF loader crashed on this file (", SignalName(sig),
        ") in its isolated process; the worker is unaffected"));
  }
  if (!reported) {
    return absl::InternalError(absl::StrCat("the isolated loader exited with status ",
                                            WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : -1,
                                            " without a report"));
  }
  if (code == 0) return absl::OkStatus();
  if (code == static_cast<int>(absl::StatusCode::kResourceExhausted) && message == "out of memory") {
    if (capped) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "loading needed more address space than the worker's own limit leaves it (RLIMIT_AS ",
          worker_as.rlim_max, " bytes, below the ", isolation.address_space_bytes,
          " bytes of LoadIsolation::address_space_bytes) and was stopped in its isolated process"));
    }
    return absl::ResourceExhaustedError(absl::StrCat(
        "loading needed more than ", isolation.address_space_bytes,
        " bytes of address space (LoadIsolation::address_space_bytes) and was stopped in its "
        "isolated process"));
  }
  if (code < 1 || code > 16) {
    return absl::InternalError(absl::StrCat("the isolated loader reported code ", code));
  }
  return absl::Status(static_cast<absl::StatusCode>(code), message);
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
  // Anonymous shared memory the child fills; closed on exec, freed with the
  // last reference (the texels' with the scene's last texture).
  HandOver hand_over;
  hand_over.scene_fd = ::memfd_create("impostor-scene", MFD_CLOEXEC);
  hand_over.texel_fd = ::memfd_create("impostor-texels", MFD_CLOEXEC);
  absl::StatusOr<Scene> scene = absl::InternalError("the isolated loader handed over no scene");
  if (hand_over.scene_fd < 0 || hand_over.texel_fd < 0) {
    scene = absl::InternalError(absl::StrCat("memfd_create: ", std::strerror(errno)));
  } else if (absl::Status loaded = RunIsolated(entry_file, limits, isolation, cancelled, hand_over); !loaded.ok()) {
    scene = loaded;
  } else {
    scene = ReadScene(hand_over);
  }
  if (hand_over.scene_fd >= 0) ::close(hand_over.scene_fd);
  if (hand_over.texel_fd >= 0) ::close(hand_over.texel_fd);
  return scene;
}

}  // namespace impostor
