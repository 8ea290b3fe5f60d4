#include "server/worker_supervisor.h"

#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "common/worker_exit_codes.h"

namespace impostor {
namespace {

// "killed by signal 11 (SIGSEGV)" or "exited with status 1".
std::string ExitDescription(int status) {
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    const char* name = ::sigabbrev_np(sig);
    return absl::StrCat("killed by signal ", sig, name ? absl::StrCat(" (SIG", name, ")") : "");
  }
  return absl::StrCat("exited with status ", WEXITSTATUS(status));
}

}  // namespace

WorkerSupervisor::WorkerSupervisor(std::filesystem::path worker_binary, std::string server_address, int count,
                                   std::vector<std::string> extra_args, ExitCallback on_exit)
    : worker_binary_(std::move(worker_binary)),
      server_address_(std::move(server_address)),
      count_(count),
      extra_args_(std::move(extra_args)),
      on_exit_(std::move(on_exit)) {}

WorkerSupervisor::~WorkerSupervisor() { Stop(); }

absl::Status WorkerSupervisor::Start() {
  if (::access(worker_binary_.c_str(), X_OK) != 0) {
    return absl::FailedPreconditionError(
        absl::StrCat("--local-workers: worker binary ", worker_binary_.string(), " is missing or not executable"));
  }
  {
    std::lock_guard lock(mu_);
    slots_.resize(static_cast<size_t>(count_));
    for (int i = 0; i < count_; ++i) slots_[i].pid = Spawn(i);
  }
  thread_ = std::thread([this] { Run(); });
  return absl::OkStatus();
}

pid_t WorkerSupervisor::Spawn(int index) {
  std::vector<std::string> args = {worker_binary_.string(), "--server", server_address_, "--name",
                                   absl::StrCat("local-", index)};
  args.insert(args.end(), extra_args_.begin(), extra_args_.end());
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid == 0) {
    // Only async-signal-safe calls between fork and exec.
    // A worker whose server died hands its job back at once (SIGINT), not
    // after a drain: nobody can take its result.
    ::prctl(PR_SET_PDEATHSIG, SIGINT);
    // The server blocks SIGTERM/SIGINT for its signal thread; a worker
    // starts with none blocked.
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    if (::getppid() != parent) ::_exit(1);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  if (pid < 0) {
    spdlog::error("event=worker_spawn_failed index={} error=\"{}\"", index, std::strerror(errno));
    return -1;
  }
  slots_[index].started = std::chrono::steady_clock::now();
  spdlog::info("event=worker_started index={} pid={}", index, pid);
  return pid;
}

void WorkerSupervisor::Run() {
  while (true) {
    int status = 0;
    // Reap whichever child exits; WNOHANG keeps the loop responsive to Stop.
    const pid_t pid = ::waitpid(-1, &status, WNOHANG);
    std::unique_lock lock(mu_);
    if (pid > 0) {
      for (size_t i = 0; i < slots_.size(); ++i) {
        Slot& slot = slots_[i];
        if (slot.pid != pid) continue;
        slot.pid = -1;
        std::string how = ExitDescription(status);
        const std::string worker_id = absl::StrCat("local-", i, "-", pid);
        if (stopping_) {
          spdlog::info("event=worker_stopped index={} pid={} how=\"{}\"", i, pid, how);
        } else if (WIFEXITED(status) &&
                   (WEXITSTATUS(status) == kWorkerExitTokenRefused || WEXITSTATUS(status) == kWorkerExitUsage)) {
          slot.parked = true;
          how += "; not restarted";
          spdlog::error("event=local_worker_parked index={} pid={} how=\"{}\" note=\"{}\"", i, pid, how,
                        WEXITSTATUS(status) == kWorkerExitTokenRefused
                            ? "the server refused the local workers' token (revoked?); restart impostor-server to "
                              "mint a new one"
                            : "the worker refused its command line; see its log");
        } else {
          const auto now = std::chrono::steady_clock::now();
          const bool died_young = now - slot.started < std::chrono::seconds(10);
          slot.backoff = died_young ? std::min(slot.backoff * 2, std::chrono::seconds(30)) : std::chrono::seconds(1);
          slot.restart_at = now + slot.backoff;
          spdlog::warn("event=worker_exited index={} pid={} how=\"{}\" restart_in_s={}", i, pid, how,
                       slot.backoff.count());
        }
        if (on_exit_) {
          // Outside the lock: the callback takes the scheduler's.
          lock.unlock();
          on_exit_(worker_id, how);
        }
        break;
      }
      continue;
    }
    if (stopping_) {
      bool any = false;
      for (const Slot& s : slots_) any = any || s.pid > 0;
      if (!any) return;
      // Past the deadline a worker still draining (or stuck in a long draw
      // call) is killed; the scheduler hears of it through on_exit_.
      if (std::chrono::steady_clock::now() >= kill_at_) {
        for (const Slot& s : slots_) {
          if (s.pid > 0) ::kill(s.pid, SIGKILL);
        }
      }
    }
    const auto now = std::chrono::steady_clock::now();
    for (size_t i = 0; i < slots_.size() && !stopping_; ++i) {
      if (slots_[i].pid < 0 && !slots_[i].parked && now >= slots_[i].restart_at) {
        ++slots_[i].restarts;
        slots_[i].pid = Spawn(static_cast<int>(i));
      }
    }
    // Children are polled every 200 ms; Stop wakes the wait at once.
    wake_.wait_for(lock, std::chrono::milliseconds(200));
  }
}

void WorkerSupervisor::Stop(std::chrono::steady_clock::time_point deadline) {
  {
    std::lock_guard lock(mu_);
    if (stopping_ && !thread_.joinable()) return;
    stopping_ = true;
    kill_at_ = deadline;
    for (const Slot& s : slots_) {
      if (s.pid > 0) ::kill(s.pid, SIGTERM);
    }
    wake_.notify_all();
  }
  if (thread_.joinable()) thread_.join();
}

}  // namespace impostor
