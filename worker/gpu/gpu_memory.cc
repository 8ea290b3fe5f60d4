#include "worker/gpu/gpu_memory.h"

#include <string>

#include "absl/strings/str_cat.h"

namespace impostor::gpu {

absl::StatusOr<uint32_t> FindMemoryType(const VkPhysicalDeviceMemoryProperties& properties,
                                        uint32_t type_bits, VkMemoryPropertyFlags required,
                                        VkMemoryPropertyFlags preferred) {
  int fallback = -1;
  for (uint32_t i = 0; i < properties.memoryTypeCount; ++i) {
    if ((type_bits & (1u << i)) == 0) continue;
    const VkMemoryPropertyFlags flags = properties.memoryTypes[i].propertyFlags;
    if ((flags & required) != required) continue;
    if ((flags & preferred) == preferred) return i;
    if (fallback < 0) fallback = static_cast<int>(i);
  }
  if (fallback >= 0) return static_cast<uint32_t>(fallback);
  return absl::InternalError(absl::StrCat("no memory type with flags 0x", absl::Hex(required),
                                          " among types 0x", absl::Hex(type_bits)));
}

absl::Status CheckDeviceLimit(std::string_view what, VkDeviceSize size, std::string_view detail,
                              VkDeviceSize limit, std::string_view limit_name,
                              std::string_view device_name) {
  if (limit == 0 || size <= limit) return absl::OkStatus();
  std::string message(what);
  absl::StrAppend(&message, ": ", size, " bytes");
  if (!detail.empty()) absl::StrAppend(&message, " (", std::string(detail), ")");
  absl::StrAppend(&message, " is over the device's ", std::string(limit_name), ", ", limit,
                  " bytes (", std::string(device_name), ")");
  return absl::ResourceExhaustedError(message);
}

absl::Status CheckBufferFits(const VulkanContext& ctx, std::string_view what, VkDeviceSize size,
                             VkBufferUsageFlags usage, std::string_view detail) {
  const std::string_view device = ctx.info().name;
  if (absl::Status s = CheckDeviceLimit(what, size, detail, ctx.max_allocation_size(),
                                        "largest allocation", device);
      !s.ok()) {
    return s;
  }
  if (absl::Status s =
          CheckDeviceLimit(what, size, detail, ctx.max_buffer_size(), "largest buffer", device);
      !s.ok()) {
    return s;
  }
  if (usage & VK_BUFFER_USAGE_STORAGE_BUFFER_BIT) {
    return CheckDeviceLimit(what, size, detail, ctx.limits().maxStorageBufferRange,
                            "largest storage buffer range", device);
  }
  return absl::OkStatus();
}

absl::Status CheckAllocationFits(const VulkanContext& ctx, std::string_view what,
                                 VkDeviceSize size, std::string_view detail) {
  return CheckDeviceLimit(what, size, detail, ctx.max_allocation_size(), "largest allocation",
                          ctx.info().name);
}

}  // namespace impostor::gpu
