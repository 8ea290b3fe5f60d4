// Single-flight, bounded-concurrency scheduling of result downloads: all
// requests for one key join one flight (one download, one result shared by
// every waiter); flights for different keys run in parallel on a fixed pool
// of threads. Urgent flights (a Get someone waits for) run before background
// ones (Prefetch), and background ones never occupy more than their share of
// the pool; a background flight that a Get joins becomes urgent.
//
// Thread-safety: every method may be called from any thread. Waiter
// callbacks run on a pool thread (or on the caller's thread, with
// CANCELLED, after Shutdown) without any lock held. A waiter callback may
// shut the coordinator down and destroy it (a Cache closed from inside its
// own callback): the pool thread it runs on is then let go instead of
// joined, and touches nothing of the coordinator's but the state it shares.
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
  // answered CANCELLED at once. Called on a pool thread (from a waiter
  // callback), it waits for the other threads and detaches that one, which
  // ends once its callbacks return without running any more Work.
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

  // Everything the pool threads use: shared with them, so that a thread
  // whose callback destroyed the coordinator can still finish its loop.
  struct State {
    State(int max_background, Work work) : max_background(max_background), work(std::move(work)) {}
    const int max_background;
    const Work work;
    std::mutex mu;
    std::condition_variable changed;
    std::map<std::string, std::shared_ptr<Flight>> flights ABSL_GUARDED_BY(mu);  // queued and running
    std::list<std::shared_ptr<Flight>> queue ABSL_GUARDED_BY(mu);                // not started, FIFO
    int running_background ABSL_GUARDED_BY(mu) = 0;
    int64_t started ABSL_GUARDED_BY(mu) = 0;
    bool shutdown ABSL_GUARDED_BY(mu) = false;

    // The next flight allowed to start, removed from the queue; nullptr if none.
    std::shared_ptr<Flight> PopRunnable() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu);
  };

  static void RunThread(const std::shared_ptr<State>& state);

  const std::shared_ptr<State> state_;
  std::vector<std::thread> threads_;  // touched by the owner only (constructor, Shutdown)
};

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_CACHE_DOWNLOAD_COORDINATOR_H_
