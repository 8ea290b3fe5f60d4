// The memory facts of the renderer's device that bound what a bake may ask
// of it (bake_memory_check.h): its largest device-local heap and its
// largest single allocation, as the VulkanContext read them (DeviceInfo).
#ifndef IMPOSTOR_WORKER_GPU_DEVICE_MEMORY_LIMITS_H_
#define IMPOSTOR_WORKER_GPU_DEVICE_MEMORY_LIMITS_H_

#include <cstdint>
#include <optional>

#include "worker/gpu/atlas_renderer.h"

namespace impostor::gpu {

struct DeviceMemoryLimits {
  // The largest VkMemoryHeap with VK_MEMORY_HEAP_DEVICE_LOCAL_BIT, bytes
  // (0: none). A CPU device's heap (lavapipe's 2 GiB) is nominal: it
  // allocates host memory, which the host check bounds.
  int64_t device_local_heap_bytes = 0;
  // VkPhysicalDeviceMaintenance3Properties::maxMemoryAllocationSize, bytes.
  int64_t max_allocation_bytes = 0;
};

// The limits `device` carries; none when it carries none (a DeviceInfo not
// made by a VulkanContext, e.g. a test's).
inline std::optional<DeviceMemoryLimits> DeviceMemoryLimitsOf(const DeviceInfo& device) {
  if (device.max_allocation_bytes <= 0) return std::nullopt;
  return DeviceMemoryLimits{.device_local_heap_bytes = device.device_local_heap_bytes,
                            .max_allocation_bytes = device.max_allocation_bytes};
}

}  // namespace impostor::gpu

#endif  // IMPOSTOR_WORKER_GPU_DEVICE_MEMORY_LIMITS_H_
