// How much host memory this worker process may use, in all and now: the
// least of what bounds it, each bound named for the messages that quote it.
//
// Bounds, each where set:
//  * the cgroup's limit (v2 memory.max, v1 memory.limit_in_bytes) of the
//    process's cgroup or any above it: a container's memory. Available now:
//    the limit less what the cgroup uses, its inactive page cache not
//    counted (the kernel reclaims that before it kills);
//  * RLIMIT_AS: the address space. Available now: the limit less the
//    process's VmSize;
//  * the machine: MemTotal, and MemAvailable now (/proc/meminfo).
// The bake check (bake_memory_check.h) compares a bake's estimate with both:
// over the total is the job's fault, over what is available only the
// worker's state at the moment.
//
// Reads files only; thread-safe.
#ifndef IMPOSTOR_WORKER_HOST_MEMORY_H_
#define IMPOSTOR_WORKER_HOST_MEMORY_H_

#include <cstdint>
#include <filesystem>
#include <string>

#include "absl/status/statusor.h"

namespace impostor {

struct HostMemory {
  int64_t total_bytes = 0;      // the most the process may ever hold
  int64_t available_bytes = 0;  // what it may add now, <= total_bytes
  std::string total_bound;      // what sets total_bytes, e.g. "cgroup memory.max"
  std::string available_bound;  // what sets available_bytes, e.g. "MemAvailable"
};

// HostMemorySources::address_space_limit: ask getrlimit.
inline constexpr int64_t kAddressSpaceLimitOfProcess = -1;

// Where the facts are read: the running system by default; tests point
// them at a tree of their own.
struct HostMemorySources {
  std::filesystem::path proc = "/proc";            // meminfo, self/cgroup, self/status
  std::filesystem::path cgroup = "/sys/fs/cgroup";  // the cgroup mount (v2, or v1 controllers)
  // RLIMIT_AS's soft limit in bytes, 0 = none.
  int64_t address_space_limit = kAddressSpaceLimitOfProcess;
};

// The bounds above. INTERNAL naming the file when /proc/meminfo cannot be
// read or lacks MemTotal (every other bound is optional).
absl::StatusOr<HostMemory> MeasureHostMemory(const HostMemorySources& sources = {});

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_HOST_MEMORY_H_
