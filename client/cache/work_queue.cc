#include "client/cache/work_queue.h"

#include <utility>

namespace impostor::sdk {

WorkQueue::WorkQueue(int threads) : state_(std::make_shared<State>()) {
  state_->active_threads = threads;
  for (int i = 0; i < threads; ++i) threads_.emplace_back([state = state_] { RunThread(state); });
}

WorkQueue::~WorkQueue() { Drain(); }

void WorkQueue::Post(std::function<void()> task) {
  {
    std::lock_guard lock(state_->mu);
    if (state_->active_threads > 0) {
      state_->tasks.push_back(std::move(task));
      state_->changed.notify_one();
      return;
    }
  }
  task();  // the pool is gone: run here rather than drop it
}

// Uses nothing but `state`: a task may destroy the queue.
void WorkQueue::RunThread(const std::shared_ptr<State>& state) {
  State& s = *state;
  std::unique_lock lock(s.mu);
  while (true) {
    s.changed.wait(lock, [&] { return s.draining || !s.tasks.empty(); });
    if (s.released == std::this_thread::get_id()) return;  // drained the queue from its last task
    if (s.tasks.empty()) {  // draining and nothing left
      --s.active_threads;
      return;
    }
    std::function<void()> task = std::move(s.tasks.front());
    s.tasks.pop_front();
    lock.unlock();
    task();
    task = nullptr;  // its captures go outside the lock
    lock.lock();
  }
}

void WorkQueue::Drain() {
  State& s = *state_;
  {
    std::lock_guard lock(s.mu);
    s.draining = true;
    s.changed.notify_all();
  }
  const std::thread::id self = std::this_thread::get_id();
  bool on_pool_thread = false;
  for (std::thread& t : threads_) {
    if (!t.joinable()) continue;
    if (t.get_id() == self) {
      on_pool_thread = true;
      t.detach();
    } else {
      t.join();
    }
  }
  threads_.clear();
  if (!on_pool_thread) return;
  // The other threads are gone; this one is inside a task. What is still
  // queued (and whatever that posts) runs here, then the pool is closed.
  std::unique_lock lock(s.mu);
  while (!s.tasks.empty()) {
    std::function<void()> task = std::move(s.tasks.front());
    s.tasks.pop_front();
    lock.unlock();
    task();
    task = nullptr;
    lock.lock();
  }
  --s.active_threads;
  s.released = self;
}

}  // namespace impostor::sdk
