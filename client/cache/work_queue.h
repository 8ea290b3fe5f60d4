// A fixed pool of threads running short tasks in FIFO order: the cache's
// answers to GetAsync that need no download (hit checks, callbacks).
//
// Thread-safety: Post may be called from any thread, also from a task. A
// task may drain and destroy the queue (a Cache closed from inside its own
// callback): see Drain.
#ifndef IMPOSTOR_CLIENT_CACHE_WORK_QUEUE_H_
#define IMPOSTOR_CLIENT_CACHE_WORK_QUEUE_H_

#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
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
  // owner only. Called from a task (on a pool thread), it waits for the
  // other threads, runs what is still queued itself, and detaches its own
  // thread, which ends when that task returns without touching the queue.
  void Drain();

 private:
  // What the pool threads use: shared with them, so that a thread whose
  // task destroyed the queue can still finish its loop.
  struct State {
    std::mutex mu;
    std::condition_variable changed;
    std::deque<std::function<void()>> tasks ABSL_GUARDED_BY(mu);
    bool draining ABSL_GUARDED_BY(mu) = false;
    // Threads not yet exited; a task posted when none is left runs inline.
    int active_threads ABSL_GUARDED_BY(mu) = 0;
    // The pool thread that drained the queue from one of its tasks: already
    // counted out of active_threads, it leaves without looking further.
    std::thread::id released ABSL_GUARDED_BY(mu);
  };

  static void RunThread(const std::shared_ptr<State>& state);

  const std::shared_ptr<State> state_;
  std::vector<std::thread> threads_;  // touched by the owner only
};

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_CACHE_WORK_QUEUE_H_
