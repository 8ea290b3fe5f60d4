#include "client/cache/download_coordinator.h"

#include <utility>

namespace impostor::sdk {

DownloadCoordinator::DownloadCoordinator(int threads, int max_background, Work work)
    : max_background_(max_background), work_(std::move(work)) {
  for (int i = 0; i < threads; ++i) threads_.emplace_back([this] { RunThread(); });
}

DownloadCoordinator::~DownloadCoordinator() { Shutdown(); }

void DownloadCoordinator::Join(const std::string& key, bool urgent, Done done) {
  std::unique_lock lock(mu_);
  if (shutdown_) {
    lock.unlock();
    done(absl::CancelledError("the cache is shutting down"));
    return;
  }
  auto it = flights_.find(key);
  if (it != flights_.end()) {
    it->second->waiters.push_back(std::move(done));
    if (urgent && !it->second->urgent) {
      it->second->urgent = true;
      changed_.notify_all();
    }
    return;
  }
  auto flight = std::make_shared<Flight>();
  flight->key = key;
  flight->urgent = urgent;
  flight->waiters.push_back(std::move(done));
  flights_[key] = flight;
  queue_.push_back(flight);
  changed_.notify_all();
}

std::shared_ptr<DownloadCoordinator::Flight> DownloadCoordinator::PopRunnable() {
  auto pick = queue_.end();
  for (auto it = queue_.begin(); it != queue_.end(); ++it) {
    if ((*it)->urgent) {
      pick = it;
      break;
    }
    if (pick == queue_.end() && running_background_ < max_background_) pick = it;
  }
  if (pick == queue_.end()) return nullptr;
  std::shared_ptr<Flight> flight = *pick;
  queue_.erase(pick);
  if (!flight->urgent) {
    flight->counts_as_background = true;
    ++running_background_;
  }
  ++started_;
  return flight;
}

void DownloadCoordinator::RunThread() {
  std::unique_lock lock(mu_);
  while (true) {
    std::shared_ptr<Flight> flight;
    changed_.wait(lock, [&] { return shutdown_ || (flight = PopRunnable()) != nullptr; });
    if (flight == nullptr) return;  // shutdown
    lock.unlock();
    Result result = work_(flight->key);
    lock.lock();
    // Under the lock, so a Join either made it into `waiters` or starts a
    // new flight.
    flights_.erase(flight->key);
    if (flight->counts_as_background) --running_background_;
    std::vector<Done> waiters = std::move(flight->waiters);
    changed_.notify_all();
    lock.unlock();
    for (size_t i = 0; i + 1 < waiters.size(); ++i) waiters[i](result);
    if (!waiters.empty()) waiters.back()(std::move(result));
    lock.lock();
  }
}

void DownloadCoordinator::Shutdown() {
  std::vector<std::shared_ptr<Flight>> cancelled;
  {
    std::lock_guard lock(mu_);
    if (shutdown_ && threads_.empty()) return;
    shutdown_ = true;
    cancelled.assign(queue_.begin(), queue_.end());
    queue_.clear();
    for (const auto& flight : cancelled) flights_.erase(flight->key);
    changed_.notify_all();
  }
  for (auto& flight : cancelled) {
    for (Done& done : flight->waiters) done(absl::CancelledError("the cache is shutting down"));
  }
  for (std::thread& t : threads_) {
    if (t.joinable()) t.join();
  }
  threads_.clear();
}

int64_t DownloadCoordinator::flights_started() {
  std::lock_guard lock(mu_);
  return started_;
}

}  // namespace impostor::sdk
