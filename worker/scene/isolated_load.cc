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
#include <string>

#include "absl/strings/str_cat.h"
#include "worker/scene/scene_wire.h"

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

// The child: limits, load, the scene into `scene_fd` (when >= 0), report
// "<code> <message>", leave.
[[noreturn]] void RunChild(int report_fd, int scene_fd, const std::filesystem::path& entry_file,
                           const GltfLoadLimits& limits, uint64_t address_space, int cpu_seconds) {
  // No locks: another thread of the parent may have held the logger's.
  if (spdlog::logger* logger = spdlog::default_logger_raw()) logger->set_level(spdlog::level::off);
  const rlimit as{address_space, address_space};
  const rlimit cpu{static_cast<rlim_t>(cpu_seconds), static_cast<rlim_t>(cpu_seconds) + 1};
  if (::setrlimit(RLIMIT_AS, &as) != 0 || ::setrlimit(RLIMIT_CPU, &cpu) != 0) {
    // Said, not just exited: "status 3 without a report" told nobody why.
    WriteAll(report_fd, absl::StrCat(static_cast<int>(absl::StatusCode::kInternal),
                                     " cannot set the loader's limits: ", std::strerror(errno)));
    ::_exit(3);
  }
  // No core files for a bomb.
  const rlimit no_core{0, 0};
  ::setrlimit(RLIMIT_CORE, &no_core);
  std::string report;
  try {
    const absl::StatusOr<Scene> scene = LoadGltfScene(entry_file, limits);
    report = absl::StrCat(static_cast<int>(scene.status().code()), " ", scene.status().message());
    if (scene.ok() && scene_fd >= 0) {
      bool written = true;
      EncodeScene(*scene, [&](std::string_view bytes) { written = written && WriteAll(scene_fd, bytes); });
      if (!written) {
        report = absl::StrCat(static_cast<int>(absl::StatusCode::kInternal),
                              " could not hand the loaded scene to the worker: ", std::strerror(errno));
      }
    }
  } catch (const std::bad_alloc&) {
    report = absl::StrCat(static_cast<int>(absl::StatusCode::kResourceExhausted), " out of memory");
  } catch (...) {
    report = absl::StrCat(static_cast<int>(absl::StatusCode::kInvalidArgument), " the loader threw");
  }
  WriteAll(report_fd, report);
  ::_exit(0);
}

std::string SignalName(int sig) {
  const char* name = ::sigabbrev_np(sig);
  return name ? absl::StrCat("SIG", name) : absl::StrCat("signal ", sig);
}

// Forks the child and returns how it ended; the child writes the scene into
// `scene_fd` when that is >= 0.
absl::Status RunIsolated(const std::filesystem::path& entry_file, const GltfLoadLimits& limits,
                         const LoadIsolation& isolation, const std::atomic<bool>* cancelled, int scene_fd) {
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
    RunChild(fds[1], scene_fd, entry_file, limits, address_space, isolation.cpu_seconds);
  }
  ::close(fds[1]);

  // Read the report until EOF, watching for cancellation and the wall limit.
  std::string report;
  const auto deadline = start + std::chrono::seconds(isolation.wall_seconds);
  absl::Status stopped;
  for (;;) {
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
      if (report.size() < kMaxReportBytes) report.append(buf, static_cast<size_t>(n));
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    break;  // EOF: the child has exited or is exiting
  }
  ::close(fds[0]);
  if (!stopped.ok()) ::kill(pid, SIGKILL);
  int wstatus = 0;
  while (::waitpid(pid, &wstatus, 0) < 0 && errno == EINTR) {
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  spdlog::debug("event=isolated_load file={} seconds={:.3f} status={}", entry_file.filename().string(),
                seconds, WIFEXITED(wstatus) ? absl::StrCat("exit ", WEXITSTATUS(wstatus))
                                            : SignalName(WTERMSIG(wstatus)));
  if (!stopped.ok()) return stopped;

  if (WIFSIGNALED(wstatus)) {
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
  if (!WIFEXITED(wstatus) || WEXITSTATUS(wstatus) != 0 || report.empty()) {
    return absl::InternalError(absl::StrCat("the isolated loader exited with status ",
                                            WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : -1,
                                            " without a report"));
  }
  const size_t space = report.find(' ');
  const int code = std::atoi(report.substr(0, space).c_str());
  const std::string message = space == std::string::npos ? "" : report.substr(space + 1);
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

// The scene the child wrote into `scene_fd`, checked (scene_wire.h).
absl::StatusOr<Scene> ReadScene(int scene_fd) {
  struct stat st {};
  if (::fstat(scene_fd, &st) != 0) return absl::InternalError(absl::StrCat("fstat: ", std::strerror(errno)));
  if (st.st_size <= 0) return absl::DataLossError("the isolated loader handed over no scene");
  const size_t size = static_cast<size_t>(st.st_size);
  void* mapped = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE, scene_fd, 0);
  if (mapped == MAP_FAILED) return absl::InternalError(absl::StrCat("mmap: ", std::strerror(errno)));
  absl::StatusOr<Scene> scene = DecodeScene(std::span(static_cast<const uint8_t*>(mapped), size));
  ::munmap(mapped, size);
  return scene;
}

}  // namespace

absl::Status CheckLoadInChild(const std::filesystem::path& entry_file, const GltfLoadLimits& limits,
                              const LoadIsolation& isolation, const std::atomic<bool>* cancelled) {
  if (!isolation.enabled) return absl::OkStatus();
  return RunIsolated(entry_file, limits, isolation, cancelled, -1);
}

absl::StatusOr<Scene> LoadSceneInChild(const std::filesystem::path& entry_file, const GltfLoadLimits& limits,
                                       const LoadIsolation& isolation, const std::atomic<bool>* cancelled) {
  if (!isolation.enabled) return LoadGltfScene(entry_file, limits);
  // Anonymous shared memory the child fills; closed on exec, freed with the
  // last reference.
  const int scene_fd = ::memfd_create("impostor-scene", MFD_CLOEXEC);
  if (scene_fd < 0) return absl::InternalError(absl::StrCat("memfd_create: ", std::strerror(errno)));
  absl::Status loaded = RunIsolated(entry_file, limits, isolation, cancelled, scene_fd);
  absl::StatusOr<Scene> scene = loaded.ok() ? ReadScene(scene_fd) : absl::StatusOr<Scene>(loaded);
  ::close(scene_fd);
  return scene;
}

}  // namespace impostor
