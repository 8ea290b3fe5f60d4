// A fixed pool of threads running short tasks in FIFO order: the cache's
// answers to GetAsync that need no download (hit checks, callbacks).
//
// Thread-safety: Post may be called from any thread, also from a task.
#ifndef IMPOSTOR_CLIENT_CACHE_WORK_QUEUE_H_
#define IMPOSTOR_CLIENT_CACHE_WORK_QUEUE_H_

#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"

namespace impostor::sdk {

class WorkQueue {
 public:
  explicit WorkQueue(int threads);
  // Drain().
  ~WorkQueue();
  WorkQueue(const WorkQueue&) = delete;
  WorkQueue& operator=(const WorkQueue&) = delete;

  void Post(std::function<void()> task);

  // Runs every task posted so far (and those they post), then stops the
  // threads. Tasks posted afterwards run on the posting thread. Call from the
  // owner only.
  void Drain();

 private:
  void RunThread();

  std::mutex mu_;
  std::condition_variable changed_;
  std::deque<std::function<void()>> tasks_ ABSL_GUARDED_BY(mu_);
  bool draining_ ABSL_GUARDED_BY(mu_) = false;
  // Threads not yet exited; a task posted when none is left runs inline.
  int active_threads_ ABSL_GUARDED_BY(mu_) = 0;
  std::vector<std::thread> threads_;
};

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_CACHE_WORK_QUEUE_H_
