// Which physical device the baker renders on (vk-bootstrap style): every
// device is inspected, unusable ones get a reason, the best usable one wins
// by type (discrete > integrated > virtual > cpu > other), ties keep the
// driver's enumeration order. An operator can pin a device by a substring of
// its name (AtlasRenderer::Create's argument, else env IMPOSTOR_VK_DEVICE).
//
// Thread-safety: the functions are stateless; Vulkan's own rules apply to the
// instance passed in.
#ifndef IMPOSTOR_WORKER_GPU_DEVICE_SELECTION_H_
#define IMPOSTOR_WORKER_GPU_DEVICE_SELECTION_H_

#include <vulkan/vulkan.h>

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"

namespace impostor::gpu {

// Formats the baker renders to; a device must support each as an optimal-
// tiling colour (or depth) attachment that can be copied out.
inline constexpr VkFormat kAlbedoFormat = VK_FORMAT_R8G8B8A8_SRGB;
inline constexpr VkFormat kNormalDepthFormat = VK_FORMAT_R16G16B16A16_UNORM;
inline constexpr VkFormat kOrmFormat = VK_FORMAT_R8G8B8A8_UNORM;
// Emissive map: colour, like albedo.
inline constexpr VkFormat kEmissiveFormat = VK_FORMAT_R8G8B8A8_SRGB;
inline constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;

struct DeviceCandidate {
  VkPhysicalDevice handle = VK_NULL_HANDLE;
  std::string name;
  VkPhysicalDeviceType type = VK_PHYSICAL_DEVICE_TYPE_OTHER;
  uint32_t api_version = 0;
  std::string driver;  // "driverName driverInfo"
  uint32_t graphics_queue_family = 0;
  // Why the device cannot (or, after ChooseDevice, will not) be used; empty
  // for a usable device and for the chosen one.
  std::string reject_reason;
};

// "discrete", "integrated", "virtual", "cpu", "other".
const char* DeviceTypeName(VkPhysicalDeviceType type);
// Lower is preferred: discrete 0, integrated 1, virtual 2, cpu 3, other 4.
int DeviceTypeRank(VkPhysicalDeviceType type);

// Queries one device's properties, features, queues and formats.
DeviceCandidate InspectPhysicalDevice(VkPhysicalDevice device);

// Pure choice among inspected candidates: the best-ranked usable one whose
// name contains `pin` (case-insensitive; empty = any). Sets reject_reason on
// every other usable candidate. UNAVAILABLE, listing every device and why it
// was passed over, when none qualifies.
absl::StatusOr<size_t> ChooseDevice(std::vector<DeviceCandidate>& candidates, std::string_view pin);

// Enumerates the instance's devices, chooses one and logs (spdlog info) one
// line for the choice and one per device passed over.
absl::StatusOr<DeviceCandidate> SelectPhysicalDevice(VkInstance instance, std::string_view pin);

}  // namespace impostor::gpu

#endif  // IMPOSTOR_WORKER_GPU_DEVICE_SELECTION_H_
