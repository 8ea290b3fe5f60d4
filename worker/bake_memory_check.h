// A bake's memory estimate (bake/bake_memory_estimate.h) against what the
// worker has, before the job downloads or renders anything.
//
// Before this check a request too large for the worker (e.g. --resolution
// 16384 needs some 15 GB of host memory) died in the bake: std::bad_alloc
// in the readback, or an unnamed Vulkan out-of-memory error, three times
// over as the job was retried, each time taking a worker down or counting
// against it. Now, as for the scratch (scratch_space.h):
//  * over what the worker has in all (host memory: the least of the cgroup
//    limit, RLIMIT_AS and MemTotal, host_memory.h; device memory: its
//    largest device-local heap, its largest allocation) is the job's fault:
//    RESOURCE_EXHAUSTED, final; the workers of a farm are set up alike.
//    The message names the estimate, the limit and what drives it, e.g.
//      "an atlas of 16384 px at supersampling 1 (frames 64) needs about
//       17.2 GB of host memory; this worker has 7.8 GB (cgroup memory.max):
//       lower --resolution"
//  * within the total but over what is available now is the worker's
//    state: UNAVAILABLE, retryable, so another worker may take it. (The
//    device's free memory now is not checked: Vulkan reports it only with
//    VK_EXT_memory_budget, per device, and a bake's device memory is
//    rarely shared.)
// Only the advice that would help is given: --supersampling when the bake
// at supersampling 1 would fit, --texture-format png when PNG maps would.
//
// Thread-safe.
#ifndef IMPOSTOR_WORKER_BAKE_MEMORY_CHECK_H_
#define IMPOSTOR_WORKER_BAKE_MEMORY_CHECK_H_

#include <optional>
#include <string>

#include "absl/status/status.h"
#include "impostor/v1/types.pb.h"
#include "common/request/bake_memory_estimate.h"
#include "worker/gpu/atlas_renderer.h"
#include "worker/gpu/device_memory_limits.h"
#include "worker/host_memory.h"

namespace impostor {

// What the worker has, as measured (or, in tests, made up).
struct WorkerMemory {
  std::optional<HostMemory> host;                   // nullopt: unknown, not checked
  std::optional<gpu::DeviceMemoryLimits> device;    // nullopt: unknown, not checked
  BakeDevice device_kind = BakeDevice::kDedicatedGpu;
  std::string device_name;                          // for messages
};

// OK when the bake of `normalised` fits `have`; else RESOURCE_EXHAUSTED or
// UNAVAILABLE as above. Pure.
absl::Status CheckBakeMemory(const v1::BakeParameters& normalised, const WorkerMemory& have);

// CheckBakeMemory against this worker: host memory measured now
// (`host_override` instead when set: a test's fake limit), the limits of
// `device` queried once per process. A fact that cannot be read is logged
// and not checked.
absl::Status CheckBakeFitsWorker(const v1::BakeParameters& normalised, const DeviceInfo& device,
                                 const std::optional<HostMemory>& host_override);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_BAKE_MEMORY_CHECK_H_
