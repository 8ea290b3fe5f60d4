// Runs N local `impostor-worker` processes for the one-machine setup and
// restarts any that exits, with exponential backoff (1 s doubling to 30 s)
// when a worker keeps dying young. Children get SIGTERM when the supervisor
// stops (they drain: finish or hand back their job), SIGKILL if they outlive
// the stop deadline, and SIGINT (hand the job back now) if the server is
// killed (PR_SET_PDEATHSIG). Every exit is reported to `on_exit` with the worker's id and how
// it ended, so the scheduler can end a dead worker's lease at once. A
// worker whose token the server refused (kWorkerExitTokenRefused: revoked,
// say) or whose command line it refused (kWorkerExitUsage) is not restarted:
// the same token and flags would be refused again, every second, forever.
//
// Thread-safety: Start and Stop from one thread; the supervisor owns one
// background thread that reaps and restarts children.
#ifndef IMPOSTOR_SERVER_WORKER_SUPERVISOR_H_
#define IMPOSTOR_SERVER_WORKER_SUPERVISOR_H_

#include <sys/types.h>

#include <condition_variable>
#include <chrono>
#include <filesystem>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"

namespace impostor {

class WorkerSupervisor {
 public:
  // Called on the supervisor's thread when a child exits: its worker id
  // ("local-<i>-<pid>", as impostor-worker names itself) and how it ended,
  // e.g. "killed by signal 11 (SIGSEGV)" or "exited with status 1" ("...;
  // not restarted" for a parked one).
  using ExitCallback = std::function<void(const std::string& worker_id, const std::string& how)>;

  // `worker_binary` is started as: worker_binary --server <server_address>
  // --name local-<i> [extra_args...].
  WorkerSupervisor(std::filesystem::path worker_binary, std::string server_address, int count,
                   std::vector<std::string> extra_args = {}, ExitCallback on_exit = nullptr);
  ~WorkerSupervisor();

  // FAILED_PRECONDITION when the worker binary is missing or not executable.
  absl::Status Start();
  // Sends SIGTERM to every child and waits for them; those still running at
  // `deadline` get SIGKILL. Returns once all are reaped.
  void Stop(std::chrono::steady_clock::time_point deadline);
  void Stop() { Stop(std::chrono::steady_clock::now() + std::chrono::seconds(5)); }

 private:
  struct Slot {
    pid_t pid = -1;
    std::chrono::steady_clock::time_point started;
    std::chrono::steady_clock::time_point restart_at;
    std::chrono::seconds backoff{1};
    int restarts = 0;
    bool parked = false;  // not restarted (see the top)
  };
  pid_t Spawn(int index) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  void Run();

  const std::filesystem::path worker_binary_;
  const std::string server_address_;
  const int count_;
  const std::vector<std::string> extra_args_;
  const ExitCallback on_exit_;

  std::mutex mu_;
  std::condition_variable wake_;
  std::vector<Slot> slots_ ABSL_GUARDED_BY(mu_);
  bool stopping_ ABSL_GUARDED_BY(mu_) = false;
  std::chrono::steady_clock::time_point kill_at_ ABSL_GUARDED_BY(mu_);
  std::thread thread_;
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_WORKER_SUPERVISOR_H_
