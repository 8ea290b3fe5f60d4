#include "server/rpc/serving_tuning.h"

#include <algorithm>
#include <thread>

#include "absl/synchronization/mutex.h"

namespace impostor {

void TuneForManyCallers(grpc::ServerBuilder& builder) {
  // Debian's abseil is built without NDEBUG, so every absl::Mutex that
  // gRPC takes also updated a global lock graph (GraphCycles::GetId showed
  // in the profile of load_bench); we have no absl::Mutex cycles to find.
  absl::SetMutexDeadlockDetectionMode(absl::OnDeadlockCycle::kIgnore);
  // The sync server lets at most MAX_POLLERS threads sit idle and ends the
  // rest: with 200 callers each burst of calls created and destroyed
  // threads (clone, munmap and TLB shootdowns were ~15% of the server's
  // time). Idle threads are cheap; keep enough of them.
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  builder.SetSyncServerOption(grpc::ServerBuilder::SyncServerOption::MIN_POLLERS, cores);
  builder.SetSyncServerOption(grpc::ServerBuilder::SyncServerOption::MAX_POLLERS, std::max(64, 8 * cores));
}

}  // namespace impostor
