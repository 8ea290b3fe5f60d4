// Single-flight, bounded-concurrency scheduling of result downloads: all
// requests for one key join one flight (one download, one result shared by
// every waiter); flights for different keys run in parallel on a fixed pool
// of threads. Urgent flights (a Get someone waits for) run before background
// ones (Prefetch), and background ones never occupy more than their share of
// the pool; a background flight that a Get joins becomes urgent.
//
// Thread-safety: every method may be called from any thread. Waiter
// callbacks run on a pool thread (or on the caller's thread, with
// CANCELLED, after Shutdown) without any lock held.
#ifndef IMPOSTOR_CLIENT_CACHE_DOWNLOAD_COORDINATOR_H_
#define IMPOSTOR_CLIENT_CACHE_DOWNLOAD_COORDINATOR_H_

#include <condition_variable>
#include <functional>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "impostor/cache.h"

namespace impostor::sdk {

class DownloadCoordinator {
 public:
  using Result = absl::StatusOr<CachedResult>;
  // Produces the result of a key: runs once per flight, on a pool thread.
  using Work = std::function<Result(const std::string& key)>;
  // Called with its own copy; the last waiter gets the flight's result
  // itself, so once every waiter has it the coordinator holds no pin on it
  // (a caller's Stats or CollectGarbage right after Get sees only its own).
  using Done = std::function<void(Result)>;

  // `threads` >= 1 pool threads, of which at most `max_background` run
  // background flights at once.
  DownloadCoordinator(int threads, int max_background, Work work);
  // Shutdown().
  ~DownloadCoordinator();
  DownloadCoordinator(const DownloadCoordinator&) = delete;
  DownloadCoordinator& operator=(const DownloadCoordinator&) = delete;

  // Adds `done` to the flight of `key`, starting one when there is none.
  void Join(const std::string& key, bool urgent, Done done);

  // Fails queued flights with CANCELLED, waits for running ones (the Work
  // must notice cancellation itself) and stops the threads. Later Joins are
  // answered CANCELLED at once.
  void Shutdown();

  // Flights started so far.
  int64_t flights_started();

 private:
  struct Flight {
    std::string key;
    bool urgent = false;
    bool counts_as_background = false;  // took a background slot when it started
    std::vector<Done> waiters;
  };

  void RunThread();
  // The next flight allowed to start, removed from the queue; nullptr if none.
  std::shared_ptr<Flight> PopRunnable() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  const int max_background_;
  const Work work_;
  std::mutex mu_;
  std::condition_variable changed_;
  std::map<std::string, std::shared_ptr<Flight>> flights_ ABSL_GUARDED_BY(mu_);  // queued and running
  std::list<std::shared_ptr<Flight>> queue_ ABSL_GUARDED_BY(mu_);                // not started, FIFO
  int running_background_ ABSL_GUARDED_BY(mu_) = 0;
  int64_t started_ ABSL_GUARDED_BY(mu_) = 0;
  bool shutdown_ ABSL_GUARDED_BY(mu_) = false;
  std::vector<std::thread> threads_;
};

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_CACHE_DOWNLOAD_COORDINATOR_H_
