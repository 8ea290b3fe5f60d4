#include "worker/scene/load_sandbox.h"

#include <malloc.h>
#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <climits>
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

std::atomic<int> started{0};

// Most of a report's message that travels (the loader caps its messages
// well below this).
constexpr size_t kMaxMessageBytes = 8192;

// What the worker sends per load, followed by the path's bytes; the two
// memfds ride along as SCM_RIGHTS (none when only the status is wanted).
struct Request {
  uint32_t path_bytes;
  int32_t cpu_seconds;
  GltfLoadLimits limits;
};

// What the sandbox answers, followed by the status message.
struct ReplyHeader {
  int32_t code;
  uint32_t retire;  // the sandbox exits after this reply
};

uint64_t PageSize() { return static_cast<uint64_t>(::sysconf(_SC_PAGESIZE)); }

// This process's address space and resident memory now, bytes
// (/proc/self/statm: size, resident, in pages).
uint64_t Statm(int field) {
  std::ifstream statm("/proc/self/statm");
  uint64_t value = 0;
  for (int i = 0; i <= field; ++i) statm >> value;
  return value * PageSize();
}

std::string SignalName(int sig) {
  const char* name = ::sigabbrev_np(sig);
  return name ? absl::StrCat("SIG", name) : absl::StrCat("signal ", sig);
}

void SendReply(int socket, int code, std::string_view message, bool retire) {
  std::string reply(sizeof(ReplyHeader), '\0');
  const ReplyHeader header{code, retire ? 1u : 0u};
  std::memcpy(reply.data(), &header, sizeof(header));
  reply.append(message.substr(0, kMaxMessageBytes));
  while (::send(socket, reply.data(), reply.size(), MSG_NOSIGNAL) < 0 && errno == EINTR) {
  }
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

// One load in the sandbox: the status's code and message, and whether the
// sandbox should stop (any failure: whatever state the loader left behind
// is not carried into the next file).
struct Report {
  int code = 0;
  std::string message;
  bool retire = false;
};

Report LoadOne(const std::filesystem::path& entry_file, const GltfLoadLimits& limits, LoadSandbox::HandOver hand_over) {
  Report report;
  try {
    // Textures are decoded straight into the worker's memfd, which it maps
    // rather than copies.
    std::optional<TexelArena> arena;
    std::optional<ScopedTexelArena> use_arena;
    if (hand_over.texel_fd >= 0) use_arena.emplace(&arena.emplace(hand_over.texel_fd));
    const absl::StatusOr<Scene> scene = LoadGltfScene(entry_file, limits);
    report.code = static_cast<int>(scene.status().code());
    report.message = std::string(scene.status().message());
    if (scene.ok() && hand_over.scene_fd >= 0) {
      bool written = true;
      EncodeScene(
          *scene, [&](std::string_view bytes) { written = written && WriteAll(hand_over.scene_fd, bytes); },
          arena ? &*arena : nullptr);
      if (!written) {
        report.code = static_cast<int>(absl::StatusCode::kInternal);
        report.message = absl::StrCat("could not hand the loaded scene to the worker: ", std::strerror(errno));
      }
    }
  } catch (const std::bad_alloc&) {
    report.code = static_cast<int>(absl::StatusCode::kResourceExhausted);
    report.message = "out of memory";
  } catch (...) {
    report.code = static_cast<int>(absl::StatusCode::kInvalidArgument);
    report.message = "the loader threw";
  }
  report.retire = report.code != 0;
  return report;
}

// The sandbox process: limits once, then one load per request until the
// worker closes its end of the socket.
[[noreturn]] void SandboxMain(int socket, uint64_t address_space) {
  // No locks: another thread of the worker may have held the logger's.
  if (spdlog::logger* logger = spdlog::default_logger_raw()) logger->set_level(spdlog::level::off);
  const rlimit as{address_space, address_space};
  if (::setrlimit(RLIMIT_AS, &as) != 0) {
    // Said, not just exited: "status 3 without a report" told nobody why.
    SendReply(socket, static_cast<int>(absl::StatusCode::kInternal),
              absl::StrCat("cannot set the loader's limits: ", std::strerror(errno)), true);
    ::_exit(3);
  }
  // No core files for a bomb.
  const rlimit no_core{0, 0};
  ::setrlimit(RLIMIT_CORE, &no_core);
  // Keep the decoders' freed buffers for the next load, as this process is
  // kept for: by default glibc hands each buffer above its mmap threshold (a
  // decoded 2048² map is 16 MiB) back to the kernel and trims the heap's
  // top, and the next load faults it all in again. On a VM that was 0.15 s
  // of a reused DamagedHelmet load (0.40 -> 0.25 s, docs/explanation/
  // figures.md). What stays is bounded: above kMaxIdleResidentBytes the
  // sandbox is replaced. Buffers over 32 MiB (glibc's highest threshold)
  // still come and go by mmap.
  ::mallopt(M_MMAP_THRESHOLD, 32 << 20);
  ::mallopt(M_TRIM_THRESHOLD, static_cast<int>(LoadSandbox::kMaxIdleResidentBytes));
  for (;;) {
    Request request{};
    char path[PATH_MAX];
    iovec iov[2] = {{&request, sizeof(request)}, {path, sizeof(path)}};
    alignas(cmsghdr) char control[CMSG_SPACE(2 * sizeof(int))];
    msghdr msg{};
    msg.msg_iov = iov;
    msg.msg_iovlen = 2;
    msg.msg_control = control;
    msg.msg_controllen = sizeof(control);
    const ssize_t n = ::recvmsg(socket, &msg, MSG_CMSG_CLOEXEC);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) ::_exit(0);  // the worker is gone, or let us go
    LoadSandbox::HandOver hand_over;
    if (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr && c->cmsg_type == SCM_RIGHTS &&
                                          c->cmsg_len == CMSG_LEN(2 * sizeof(int))) {
      int fds[2];
      std::memcpy(fds, CMSG_DATA(c), sizeof(fds));
      hand_over = {fds[0], fds[1]};
    }
    if (static_cast<size_t>(n) < sizeof(request) || request.path_bytes != static_cast<size_t>(n) - sizeof(request)) {
      SendReply(socket, static_cast<int>(absl::StatusCode::kInternal), "malformed load request", true);
      ::_exit(4);
    }
    // This load's CPU seconds on top of what the process has used.
    rusage usage{};
    ::getrusage(RUSAGE_SELF, &usage);
    rlimit cpu{};
    ::getrlimit(RLIMIT_CPU, &cpu);
    cpu.rlim_cur = std::min<rlim_t>(
        static_cast<rlim_t>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec + 1 + request.cpu_seconds), cpu.rlim_max);
    ::setrlimit(RLIMIT_CPU, &cpu);

    Report report = LoadOne(std::string(path, request.path_bytes), request.limits, hand_over);
    if (hand_over.scene_fd >= 0) ::close(hand_over.scene_fd);
    if (hand_over.texel_fd >= 0) ::close(hand_over.texel_fd);
    if (Statm(1) > LoadSandbox::kMaxIdleResidentBytes) report.retire = true;
    SendReply(socket, report.code, report.message, report.retire);
    if (report.retire) ::_exit(0);
  }
}

}  // namespace

int LoadSandbox::Started() { return started.load(); }

absl::StatusOr<std::unique_ptr<LoadSandbox>> LoadSandbox::Start(uint64_t address_space_bytes) {
  int sv[2];
  if (::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, sv) != 0) {
    return absl::InternalError(absl::StrCat("socketpair: ", std::strerror(errno)));
  }
  std::unique_ptr<LoadSandbox> sandbox(new LoadSandbox());
  sandbox->address_space_bytes_ = address_space_bytes;
  // The sandbox can lower its limits but never raise them past the
  // worker's own hard RLIMIT_AS (a container or `ulimit -v`): asking for
  // more failed setrlimit and every load with it. Within that limit the
  // loader gets what is left, and a load that needs more is the usual
  // out-of-memory refusal.
  uint64_t address_space = Statm(0) + address_space_bytes;
  rlimit worker_as{};
  if (::getrlimit(RLIMIT_AS, &worker_as) == 0 && worker_as.rlim_max != RLIM_INFINITY &&
      worker_as.rlim_max < address_space) {
    address_space = worker_as.rlim_max;
    sandbox->capped_at_ = worker_as.rlim_max;
  }
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(sv[0]);
    ::close(sv[1]);
    return absl::InternalError(absl::StrCat("fork: ", std::strerror(errno)));
  }
  if (pid == 0) {
    // Its end of the socket as fd 3 and nothing else of the worker's open
    // (other sandboxes' sockets included): it sees EOF when the worker goes.
    if (sv[1] != 3 && ::dup2(sv[1], 3) < 0) ::_exit(5);
    ::close_range(4, ~0U, 0);
    SandboxMain(3, address_space);
  }
  ::close(sv[1]);
  sandbox->pid_ = pid;
  sandbox->socket_ = sv[0];
  started.fetch_add(1);
  return sandbox;
}

LoadSandbox::~LoadSandbox() { Kill(); }

void LoadSandbox::Kill() {
  if (socket_ >= 0) ::close(socket_);
  socket_ = -1;
  if (pid_ > 0) {
    ::kill(pid_, SIGKILL);
    while (::waitpid(pid_, nullptr, 0) < 0 && errno == EINTR) {
    }
  }
  pid_ = -1;
}

LoadSandbox::Outcome LoadSandbox::Load(const std::filesystem::path& entry_file, const GltfLoadLimits& limits,
                                       int cpu_seconds, int wall_seconds, const std::atomic<bool>* cancelled,
                                       HandOver hand_over) {
  Outcome outcome;
  const std::string path = entry_file.string();
  if (path.size() >= PATH_MAX) {
    outcome.status = absl::InvalidArgumentError(absl::StrCat("input path of ", path.size(), " bytes, over PATH_MAX"));
    outcome.reusable = pid_ > 0;
    return outcome;
  }
  if (pid_ <= 0) {
    outcome.status = absl::InternalError("the loader's process is gone");
    return outcome;
  }
  ++loads_;
  Request request{static_cast<uint32_t>(path.size()), cpu_seconds, limits};
  iovec iov[2] = {{&request, sizeof(request)}, {const_cast<char*>(path.data()), path.size()}};
  alignas(cmsghdr) char control[CMSG_SPACE(2 * sizeof(int))] = {};
  msghdr msg{};
  msg.msg_iov = iov;
  msg.msg_iovlen = 2;
  if (hand_over.scene_fd >= 0 && hand_over.texel_fd >= 0) {
    msg.msg_control = control;
    msg.msg_controllen = sizeof(control);
    cmsghdr* c = CMSG_FIRSTHDR(&msg);
    c->cmsg_level = SOL_SOCKET;
    c->cmsg_type = SCM_RIGHTS;
    c->cmsg_len = CMSG_LEN(2 * sizeof(int));
    const int fds[2] = {hand_over.scene_fd, hand_over.texel_fd};
    std::memcpy(CMSG_DATA(c), fds, sizeof(fds));
  }
  ssize_t sent;
  while ((sent = ::sendmsg(socket_, &msg, MSG_NOSIGNAL)) < 0 && errno == EINTR) {
  }

  // The reply, watching for cancellation and the wall limit.
  const auto deadline = Clock::now() + std::chrono::seconds(wall_seconds);
  std::string reply;
  absl::Status stopped;
  bool ended = sent < 0;  // the process is gone (or going): no reply will come
  while (!ended) {
    if (cancelled && *cancelled) {
      stopped = absl::CancelledError("cancelled while loading");
      break;
    }
    if (Clock::now() > deadline) {
      stopped = absl::ResourceExhaustedError(
          absl::StrCat("loading took longer than ", wall_seconds, " s (LoadIsolation::wall_seconds)"));
      break;
    }
    pollfd p{socket_, POLLIN, 0};
    if (::poll(&p, 1, 50) <= 0) continue;  // timeout (or EINTR): check again
    reply.resize(sizeof(ReplyHeader) + kMaxMessageBytes);
    const ssize_t n = ::recv(socket_, reply.data(), reply.size(), 0);
    if (n < 0 && errno == EINTR) continue;
    if (n < static_cast<ssize_t>(sizeof(ReplyHeader))) {
      ended = true;  // EOF: the process died without a reply
      reply.clear();
      break;
    }
    reply.resize(static_cast<size_t>(n));
    break;
  }
  if (!stopped.ok()) {
    Kill();
    outcome.status = stopped;
    return outcome;
  }
  if (ended) {
    // How the process ended says why.
    ::close(socket_);
    socket_ = -1;
    int wstatus = 0;
    while (::waitpid(pid_, &wstatus, 0) < 0 && errno == EINTR) {
    }
    pid_ = -1;
    outcome.process_failed = true;
    if (WIFSIGNALED(wstatus)) {
      const int sig = WTERMSIG(wstatus);
      if (sig == SIGXCPU || sig == SIGKILL) {
        outcome.status = absl::ResourceExhaustedError(absl::StrCat(
            "loading was stopped by ", SignalName(sig), " after ", cpu_seconds,
            " CPU seconds at most (LoadIsolation::cpu_seconds) or by the kernel for memory"));
      } else {
        outcome.status = absl::InvalidArgumentError(absl::StrCat(
            "the glTF loader crashed on this file (", SignalName(sig), ") in its isolated process; the worker is unaffected"));
      }
    } else {
      outcome.status = absl::InternalError(absl::StrCat("the isolated loader exited with status ",
                                                        WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : -1,
                                                        " without a report"));
    }
    return outcome;
  }

  ReplyHeader header{};
  std::memcpy(&header, reply.data(), sizeof(header));
  const std::string message = reply.substr(sizeof(header));
  outcome.reusable = header.code == 0 && header.retire == 0 && loads_ < kMaxLoads;
  if (!outcome.reusable) Kill();
  if (header.code == 0) return outcome;
  if (header.code == static_cast<int>(absl::StatusCode::kResourceExhausted) && message == "out of memory") {
    outcome.process_failed = true;
    if (capped_at_ != 0) {
      outcome.status = absl::ResourceExhaustedError(absl::StrCat(
          "loading needed more address space than the worker's own limit leaves it (RLIMIT_AS ", capped_at_,
          " bytes, below the ", address_space_bytes_,
          " bytes of LoadIsolation::address_space_bytes) and was stopped in its isolated process"));
    } else {
      outcome.status = absl::ResourceExhaustedError(
          absl::StrCat("loading needed more than ", address_space_bytes_,
                       " bytes of address space (LoadIsolation::address_space_bytes) and was stopped in its "
                       "isolated process"));
    }
    return outcome;
  }
  if (header.code < 1 || header.code > 16) {
    outcome.status = absl::InternalError(absl::StrCat("the isolated loader reported code ", header.code));
    return outcome;
  }
  outcome.status = absl::Status(static_cast<absl::StatusCode>(header.code), message);
  return outcome;
}

}  // namespace impostor
