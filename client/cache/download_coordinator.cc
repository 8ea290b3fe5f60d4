#include "client/cache/download_coordinator.h"

#include <utility>

namespace impostor::sdk {

DownloadCoordinator::DownloadCoordinator(int threads, int max_background, Work work)
    : state_(std::make_shared<State>(max_background, std::move(work))), max_threads_(threads) {}

DownloadCoordinator::~DownloadCoordinator() { Shutdown(); }

void DownloadCoordinator::Join(const std::string& key, bool urgent, Done done, int priority) {
  State& s = *state_;
  std::unique_lock lock(s.mu);
  if (s.shutdown) {
    lock.unlock();
    done(absl::CancelledError("the cache is shutting down"));
    return;
  }
  auto it = s.flights.find(key);
  // A running flight that was cancelled is ending: a new one takes its key.
  if (it != s.flights.end() && !(it->second->running && it->second->cancel->cancelled())) {
    it->second->waiters.push_back(std::move(done));
    if (!it->second->running) it->second->priority = priority;
    if (urgent && !it->second->urgent) {
      it->second->urgent = true;
      s.changed.notify_one();  // it may run now (no background slot needed): one thread suffices
    }
    return;
  }
  auto flight = std::make_shared<Flight>();
  flight->key = key;
  flight->urgent = urgent;
  flight->priority = priority;
  flight->order = s.next_order++;
  flight->waiters.push_back(std::move(done));
  s.flights[key] = flight;
  s.queue.push_back(flight);
  // A thread per flight that wants one, up to the limit: a cache that never
  // runs more than a few downloads at once keeps only a few threads.
  if (static_cast<int>(threads_.size()) < max_threads_ &&
      s.queue.size() + static_cast<size_t>(s.running) > threads_.size()) {
    threads_.emplace_back([state = state_] { RunThread(state); });
  }
  // One new flight needs one thread: waking every idle one would only make
  // them all queue on `mu` for it.
  s.changed.notify_one();
}

std::shared_ptr<DownloadCoordinator::Flight> DownloadCoordinator::State::PopRunnable() {
  auto pick = queue.end();
  for (auto it = queue.begin(); it != queue.end(); ++it) {
    if ((*it)->urgent) {
      pick = it;
      break;
    }
    if (running_background >= max_background) continue;
    if (pick == queue.end() || (*it)->priority > (*pick)->priority ||
        ((*it)->priority == (*pick)->priority && (*it)->order < (*pick)->order)) {
      pick = it;
    }
  }
  if (pick == queue.end()) return nullptr;
  std::shared_ptr<Flight> flight = *pick;
  queue.erase(pick);
  flight->running = true;
  ++running;
  if (!flight->urgent) {
    flight->counts_as_background = true;
    ++running_background;
  }
  ++started;
  return flight;
}

// Uses nothing but `state`: a waiter callback may destroy the coordinator.
void DownloadCoordinator::RunThread(const std::shared_ptr<State>& state) {
  State& s = *state;
  std::unique_lock lock(s.mu);
  while (true) {
    std::shared_ptr<Flight> flight;
    s.changed.wait(lock, [&] { return s.shutdown || (flight = s.PopRunnable()) != nullptr; });
    if (flight == nullptr) return;  // shutdown
    lock.unlock();
    Result result = s.work(flight->key, *flight->cancel);
    lock.lock();
    // Under the lock, so a Join either made it into `waiters` or starts a
    // new flight.
    if (auto f = s.flights.find(flight->key); f != s.flights.end() && f->second == flight) s.flights.erase(f);
    --s.running;
    if (flight->counts_as_background) --s.running_background;
    std::vector<Done> waiters = std::move(flight->waiters);
    // No wake-up: what this flight's end lets start (the background slot it
    // frees) this thread picks itself when it looks for its next flight.
    lock.unlock();
    for (size_t i = 0; i + 1 < waiters.size(); ++i) waiters[i](result);
    if (!waiters.empty()) waiters.back()(std::move(result));
    waiters.clear();  // the callbacks' captures go before the next flight
    lock.lock();
  }
}

bool DownloadCoordinator::Cancel(const std::string& key) {
  State& s = *state_;
  std::shared_ptr<Flight> flight;
  std::vector<Done> dropped;
  bool running;
  {
    std::lock_guard lock(s.mu);
    auto it = s.flights.find(key);
    if (it == s.flights.end() || it->second->urgent) return false;
    flight = it->second;
    running = flight->running;
    if (!running) {
      s.queue.remove(flight);
      s.flights.erase(it);
      dropped = std::move(flight->waiters);
    }
  }
  if (!running) {
    for (Done& done : dropped) done(flight->cancel->error());
    return true;
  }
  flight->cancel->Cancel();
  return true;
}

void DownloadCoordinator::Shutdown() {
  std::vector<std::shared_ptr<Flight>> cancelled;
  {
    State& s = *state_;
    std::lock_guard lock(s.mu);
    if (s.shutdown && threads_.empty()) return;
    s.shutdown = true;
    cancelled.assign(s.queue.begin(), s.queue.end());
    s.queue.clear();
    for (const auto& flight : cancelled) s.flights.erase(flight->key);
    s.changed.notify_all();
  }
  for (auto& flight : cancelled) {
    for (Done& done : flight->waiters) done(absl::CancelledError("the cache is shutting down"));
  }
  // No Join starts a thread once `shutdown` is set: threads_ holds them all.
  const std::thread::id self = std::this_thread::get_id();
  for (std::thread& t : threads_) {
    if (!t.joinable()) continue;
    if (t.get_id() == self) {
      t.detach();  // we are in its callback: it ends when that returns
    } else {
      t.join();
    }
  }
  threads_.clear();
}

int64_t DownloadCoordinator::flights_started() {
  std::lock_guard lock(state_->mu);
  return state_->started;
}

}  // namespace impostor::sdk
