// Runs N local `impostor-worker` processes for the one-machine setup and
// restarts any that exits, with exponential backoff (1 s doubling to 30 s)
// when a worker keeps dying young. Children get SIGTERM when the supervisor
// stops and die with the server (PR_SET_PDEATHSIG) if it is killed.
//
// Thread-safety: Start and Stop from one thread; the supervisor owns one
// background thread that reaps and restarts children.
#ifndef IMPOSTOR_SERVER_WORKER_SUPERVISOR_H_
#define IMPOSTOR_SERVER_WORKER_SUPERVISOR_H_

#include <sys/types.h>

#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"

namespace impostor {

class WorkerSupervisor {
 public:
  // `worker_binary` is started as: worker_binary --server <server_address>
  // --name local-<i> [extra_args...].
  WorkerSupervisor(std::filesystem::path worker_binary, std::string server_address, int count,
                   std::vector<std::string> extra_args = {});
  ~WorkerSupervisor();

  // FAILED_PRECONDITION when the worker binary is missing or not executable.
  absl::Status Start();
  // Terminates every child and waits for them.
  void Stop();

 private:
  struct Slot {
    pid_t pid = -1;
    std::chrono::steady_clock::time_point started;
    std::chrono::steady_clock::time_point restart_at;
    std::chrono::seconds backoff{1};
    int restarts = 0;
  };
  pid_t Spawn(int index) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  void Run();

  const std::filesystem::path worker_binary_;
  const std::string server_address_;
  const int count_;
  const std::vector<std::string> extra_args_;

  std::mutex mu_;
  std::condition_variable wake_;
  std::vector<Slot> slots_ ABSL_GUARDED_BY(mu_);
  bool stopping_ ABSL_GUARDED_BY(mu_) = false;
  std::chrono::steady_clock::time_point stop_requested_ ABSL_GUARDED_BY(mu_);
  std::thread thread_;
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_WORKER_SUPERVISOR_H_
