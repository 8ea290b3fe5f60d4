// Small helpers the bake_scheduler_*.cc files share; not for use outside
// server/scheduler/.
#ifndef IMPOSTOR_SERVER_SCHEDULER_SCHEDULER_INTERNAL_H_
#define IMPOSTOR_SERVER_SCHEDULER_SCHEDULER_INTERNAL_H_

#include <chrono>
#include <cstdint>

#include "impostor/v1/types.pb.h"
#include "server/blobs/blob_store.h"

namespace impostor::scheduler_internal {

// Finished leaders whose waiting followers one lease sweep settles.
inline constexpr int kStrandedLeadersPerSweep = 100;

inline bool IsTerminal(v1::JobState s) {
  return s == v1::JOB_STATE_SUCCEEDED || s == v1::JOB_STATE_FAILED || s == v1::JOB_STATE_CANCELLED;
}

inline BlobDigest ToDigest(const v1::Digest& d) { return {d.hash(), d.size_bytes()}; }

inline int64_t SystemNowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace impostor::scheduler_internal

#endif  // IMPOSTOR_SERVER_SCHEDULER_SCHEDULER_INTERNAL_H_
