#include "worker/gpu/gpu_memory.h"

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

}  // namespace impostor::gpu
