// Single-flight, bounded-concurrency scheduling of result downloads: all
// requests for one key join one flight (one download, one result shared by
// every waiter); flights for different keys run in parallel on a pool of
// threads, started as flights need them (never more than the flights that
// ran or waited at once, up to the limit) and kept until Shutdown. Urgent
// flights (a Get someone waits for) run before background ones (Prefetch),
// and background ones never occupy more than their share of the pool; a
// background flight that a Get joins becomes urgent. Background
// flights start in order of priority (higher first; equal ones in the order
// asked), which a later Join may change while the flight waits, and a
// background flight no Get waits for can be cancelled, queued or running
// (its work sees its CancelSource cancelled).
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
#include "client/transport/retry.h"
#include "impostor/cache.h"

namespace impostor::sdk {

class DownloadCoordinator {
 public:
  using Result = absl::StatusOr<CachedResult>;
  // Produces the result of a key: runs once per flight, on a pool thread.
  // `cancel` is the flight's: cancelled by Cancel(key) (a prefetch no longer
  // wanted); the work should end promptly with its error.
  using Work = std::function<Result(const std::string& key, CancelSource& cancel)>;
  // Called with its own copy; the last waiter gets the flight's result
  // itself, so once every waiter has it the coordinator holds no pin on it
  // (a caller's Stats or CollectGarbage right after Get sees only its own).
  using Done = std::function<void(Result)>;

  // At most `threads` >= 1 pool threads (none until the first Join), of
  // which at most `max_background` run background flights at once.
  DownloadCoordinator(int threads, int max_background, Work work);
  // Shutdown().
  ~DownloadCoordinator();
  DownloadCoordinator(const DownloadCoordinator&) = delete;
  DownloadCoordinator& operator=(const DownloadCoordinator&) = delete;

  // Adds `done` to the flight of `key`, starting one when there is none.
  // `priority` orders background flights; joining a flight that has not
  // started sets its priority to this one (a re-prioritised prefetch).
  void Join(const std::string& key, bool urgent, Done done, int priority = 0);

  // Cancels the flight of `key` unless a Get (urgent) waits for it: a
  // queued one is dropped and its waiters answered CANCELLED at once; a
  // running one has its CancelSource cancelled (the work keeps what it
  // downloaded for a later resume). True when a flight was cancelled.
  bool Cancel(const std::string& key);

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
    bool running = false;
    int priority = 0;
    uint64_t order = 0;  // when it was queued, for FIFO among equals
    std::shared_ptr<CancelSource> cancel = std::make_shared<CancelSource>("the prefetch was cancelled");
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
    int running ABSL_GUARDED_BY(mu) = 0;  // flights started and not ended
    int running_background ABSL_GUARDED_BY(mu) = 0;
    int64_t started ABSL_GUARDED_BY(mu) = 0;
    uint64_t next_order ABSL_GUARDED_BY(mu) = 0;
    bool shutdown ABSL_GUARDED_BY(mu) = false;

    // The next flight allowed to start, removed from the queue; nullptr if none.
    std::shared_ptr<Flight> PopRunnable() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu);
  };

  static void RunThread(const std::shared_ptr<State>& state);

  const std::shared_ptr<State> state_;
  const int max_threads_;
  // Added by Join under state_->mu while not shut down; Shutdown reads it
  // once `shutdown` is set (nothing adds to it then).
  std::vector<std::thread> threads_;
};

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_CACHE_DOWNLOAD_COORDINATOR_H_
