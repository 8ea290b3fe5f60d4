// Device memory allocation for buffers and images. The baker allocates one
// VkDeviceMemory per resource: a bake has a few dozen resources at most, far
// below maxMemoryAllocationCount (>= 4096), so a sub-allocator would buy
// nothing.
#ifndef IMPOSTOR_WORKER_GPU_GPU_MEMORY_H_
#define IMPOSTOR_WORKER_GPU_GPU_MEMORY_H_

#include <vulkan/vulkan.h>

#include <cstdint>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "worker/gpu/vulkan_context.h"

namespace impostor::gpu {

// Index of a memory type allowed by `type_bits` that has every `required`
// flag, preferring one that also has every `preferred` flag. INTERNAL when
// none has the required flags.
absl::StatusOr<uint32_t> FindMemoryType(const VkPhysicalDeviceMemoryProperties& properties,
                                        uint32_t type_bits, VkMemoryPropertyFlags required,
                                        VkMemoryPropertyFlags preferred = 0);

// OK when `size` bytes are at most `limit` (0: the device states none).
// Otherwise RESOURCE_EXHAUSTED, final for the job (bad input, not a sick
// worker), naming what is too large and the limit, e.g.
//   "vertex buffer: 2160000000 bytes (30000000 vertices after instancing) is
//    over the device's largest allocation, 2147483648 bytes (llvmpipe ...)"
// `detail` (may be empty) follows the size in parentheses.
absl::Status CheckDeviceLimit(std::string_view what, VkDeviceSize size, std::string_view detail,
                              VkDeviceSize limit, std::string_view limit_name,
                              std::string_view device_name);

// A buffer of `size` bytes with `usage` against the device's largest buffer
// (maintenance4), largest allocation (maintenance3) and, when bound as a
// storage buffer, maxStorageBufferRange. Vulkan does not check these itself:
// drivers may crash (lavapipe segfaulted copying a 2.16 GB vertex buffer).
absl::Status CheckBufferFits(const VulkanContext& ctx, std::string_view what, VkDeviceSize size,
                             VkBufferUsageFlags usage, std::string_view detail = {});

// An allocation of `size` bytes (a VkMemoryRequirements::size) against the
// device's largest allocation.
absl::Status CheckAllocationFits(const VulkanContext& ctx, std::string_view what,
                                 VkDeviceSize size, std::string_view detail = {});

}  // namespace impostor::gpu

#endif  // IMPOSTOR_WORKER_GPU_GPU_MEMORY_H_
