// What the scheduler tells observers (metrics) about the events it decides.
// The scheduler calls these with its mutex held, right after the event is
// saved: an implementation must be quick, must not block and must not call
// back into the scheduler. The default implementations do nothing.
#ifndef IMPOSTOR_SERVER_SCHEDULER_SCHEDULER_OBSERVER_H_
#define IMPOSTOR_SERVER_SCHEDULER_SCHEDULER_OBSERVER_H_

#include <cstdint>
#include <string>

#include "impostor/v1/types.pb.h"

namespace impostor {

class SchedulerObserver {
 public:
  virtual ~SchedulerObserver() = default;

  // How SubmitBake was answered (only accepted submits are reported).
  enum class SubmitOutcome {
    kCacheHit,    // answered from the result cache
    kQueued,      // a new bake was queued
    kSharedBake,  // follows an identical bake already queued or running
    kRetry,       // a resent request id: the first submit's job again
  };
  virtual void OnSubmit(v1::Product product, SubmitOutcome outcome) {}
  // A job was leased; `queued_seconds` is the time from its submit to this
  // lease, `attempt` counts from 1.
  virtual void OnLease(const std::string& worker_id, v1::Product product, uint32_t attempt, double queued_seconds) {}
  // A worker delivered a result (its timings are in result.timings()).
  virtual void OnComplete(const std::string& worker_id, const v1::Manifest& result) {}
  // A worker reported failure; `will_retry` when the job was queued again.
  virtual void OnFail(const std::string& worker_id, v1::Product product, bool will_retry) {}
  // A lease ended without a report: expired, or the worker process died.
  virtual void OnLeaseLost(const std::string& worker_id, v1::Product product) {}
  // EnforceStoreCap removed blobs and results.
  virtual void OnEvicted(int64_t blobs, int64_t results, int64_t bytes) {}
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_SCHEDULER_SCHEDULER_OBSERVER_H_
