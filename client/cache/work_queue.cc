#include "client/cache/work_queue.h"

#include <utility>

namespace impostor::sdk {

WorkQueue::WorkQueue(int threads) {
  active_threads_ = threads;
  for (int i = 0; i < threads; ++i) threads_.emplace_back([this] { RunThread(); });
}

WorkQueue::~WorkQueue() { Drain(); }

void WorkQueue::Post(std::function<void()> task) {
  {
    std::lock_guard lock(mu_);
    if (active_threads_ > 0) {
      tasks_.push_back(std::move(task));
      changed_.notify_one();
      return;
    }
  }
  task();  // the pool is gone: run here rather than drop it
}

void WorkQueue::RunThread() {
  std::unique_lock lock(mu_);
  while (true) {
    changed_.wait(lock, [&] { return draining_ || !tasks_.empty(); });
    if (tasks_.empty()) {  // draining and nothing left
      --active_threads_;
      return;
    }
    std::function<void()> task = std::move(tasks_.front());
    tasks_.pop_front();
    lock.unlock();
    task();
    lock.lock();
  }
}

void WorkQueue::Drain() {
  {
    std::lock_guard lock(mu_);
    draining_ = true;
    changed_.notify_all();
  }
  for (std::thread& t : threads_) {
    if (t.joinable()) t.join();
  }
}

}  // namespace impostor::sdk
