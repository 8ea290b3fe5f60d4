// Device memory allocation for buffers and images. The baker allocates one
// VkDeviceMemory per resource: a bake has a few dozen resources at most, far
// below maxMemoryAllocationCount (>= 4096), so a sub-allocator would buy
// nothing.
#ifndef IMPOSTOR_WORKER_GPU_GPU_MEMORY_H_
#define IMPOSTOR_WORKER_GPU_GPU_MEMORY_H_

#include <vulkan/vulkan.h>

#include <cstdint>

#include "absl/status/statusor.h"

namespace impostor::gpu {

// Index of a memory type allowed by `type_bits` that has every `required`
// flag, preferring one that also has every `preferred` flag. INTERNAL when
// none has the required flags.
absl::StatusOr<uint32_t> FindMemoryType(const VkPhysicalDeviceMemoryProperties& properties,
                                        uint32_t type_bits, VkMemoryPropertyFlags required,
                                        VkMemoryPropertyFlags preferred = 0);

}  // namespace impostor::gpu

#endif  // IMPOSTOR_WORKER_GPU_GPU_MEMORY_H_
