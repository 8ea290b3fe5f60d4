#include "worker/gpu/device_selection.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "worker/gpu/vk_check.h"

namespace impostor::gpu {
namespace {

std::string ApiVersionString(uint32_t v) {
  return absl::StrCat(VK_API_VERSION_MAJOR(v), ".", VK_API_VERSION_MINOR(v), ".",
                      VK_API_VERSION_PATCH(v));
}

std::string Lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

// Empty when `format` has all `needed` optimal-tiling features, else a reason.
std::string MissingFormatFeatures(VkPhysicalDevice device, VkFormat format, const char* name,
                                  VkFormatFeatureFlags needed) {
  VkFormatProperties props{};
  vkGetPhysicalDeviceFormatProperties(device, format, &props);
  if ((props.optimalTilingFeatures & needed) == needed) return "";
  return absl::StrCat(name, " lacks optimal-tiling features 0x",
                      absl::Hex(needed & ~props.optimalTilingFeatures));
}

}  // namespace

const char* DeviceTypeName(VkPhysicalDeviceType type) {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
      return "discrete";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
      return "integrated";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
      return "virtual";
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
      return "cpu";
    default:
      return "other";
  }
}

int DeviceTypeRank(VkPhysicalDeviceType type) {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
      return 0;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
      return 1;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
      return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
      return 3;
    default:
      return 4;
  }
}

DeviceCandidate InspectPhysicalDevice(VkPhysicalDevice device) {
  DeviceCandidate c;
  c.handle = device;

  VkPhysicalDeviceVulkan12Properties props12{};
  props12.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_PROPERTIES;
  VkPhysicalDeviceProperties2 props{};
  props.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
  // The 1.2 properties struct may only be chained on a 1.2+ device; read the
  // core properties first to know.
  vkGetPhysicalDeviceProperties(device, &props.properties);
  c.name = props.properties.deviceName;
  c.type = props.properties.deviceType;
  c.api_version = props.properties.apiVersion;
  if (c.api_version < VK_API_VERSION_1_3) {
    c.reject_reason =
        absl::StrCat("supports Vulkan ", ApiVersionString(c.api_version), ", needs 1.3");
    return c;
  }
  props.pNext = &props12;
  vkGetPhysicalDeviceProperties2(device, &props);
  c.driver = absl::StrCat(props12.driverName, " ", props12.driverInfo);

  VkPhysicalDeviceVulkan13Features features13{};
  features13.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES;
  VkPhysicalDeviceFeatures2 features{};
  features.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
  features.pNext = &features13;
  vkGetPhysicalDeviceFeatures2(device, &features);
  if (!features13.dynamicRendering) {
    c.reject_reason = "no dynamicRendering";
    return c;
  }
  if (!features13.synchronization2) {
    c.reject_reason = "no synchronization2";
    return c;
  }

  uint32_t family_count = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(device, &family_count, nullptr);
  std::vector<VkQueueFamilyProperties> families(family_count);
  vkGetPhysicalDeviceQueueFamilyProperties(device, &family_count, families.data());
  bool found_queue = false;
  for (uint32_t i = 0; i < family_count; ++i) {
    if (families[i].queueCount > 0 && (families[i].queueFlags & VK_QUEUE_GRAPHICS_BIT)) {
      c.graphics_queue_family = i;
      found_queue = true;
      break;
    }
  }
  if (!found_queue) {
    c.reject_reason = "no graphics queue";
    return c;
  }

  constexpr VkFormatFeatureFlags kColorTarget =
      VK_FORMAT_FEATURE_COLOR_ATTACHMENT_BIT | VK_FORMAT_FEATURE_TRANSFER_SRC_BIT;
  constexpr VkFormatFeatureFlags kTexture =
      VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT | VK_FORMAT_FEATURE_TRANSFER_DST_BIT;
  for (std::string reason :
       {MissingFormatFeatures(device, kAlbedoFormat, "R8G8B8A8_SRGB", kColorTarget | kTexture),
        MissingFormatFeatures(device, kNormalDepthFormat, "R16G16B16A16_UNORM", kColorTarget),
        MissingFormatFeatures(device, kOrmFormat, "R8G8B8A8_UNORM", kColorTarget | kTexture),
        MissingFormatFeatures(device, kDepthFormat, "D32_SFLOAT",
                              VK_FORMAT_FEATURE_DEPTH_STENCIL_ATTACHMENT_BIT)}) {
    if (!reason.empty()) {
      c.reject_reason = std::move(reason);
      return c;
    }
  }
  return c;
}

absl::StatusOr<size_t> ChooseDevice(std::vector<DeviceCandidate>& candidates,
                                    std::string_view pin) {
  const std::string pin_lower = Lower(pin);
  int best = -1;
  for (size_t i = 0; i < candidates.size(); ++i) {
    DeviceCandidate& c = candidates[i];
    if (!c.reject_reason.empty()) continue;
    if (!pin_lower.empty() && Lower(c.name).find(pin_lower) == std::string::npos) {
      c.reject_reason = absl::StrCat("name does not contain the pinned \"", std::string(pin), "\"");
      continue;
    }
    if (best < 0 || DeviceTypeRank(c.type) < DeviceTypeRank(candidates[best].type)) {
      best = static_cast<int>(i);
    }
  }
  if (best < 0) {
    std::vector<std::string> reasons;
    for (const DeviceCandidate& c : candidates) {
      reasons.push_back(absl::StrCat(c.name, ": ", c.reject_reason));
    }
    if (reasons.empty()) reasons.push_back("no Vulkan devices");
    return absl::UnavailableError(
        absl::StrCat("no usable Vulkan 1.3 device (", absl::StrJoin(reasons, "; "), ")"));
  }
  for (size_t i = 0; i < candidates.size(); ++i) {
    DeviceCandidate& c = candidates[i];
    if (static_cast<int>(i) == best || !c.reject_reason.empty()) continue;
    c.reject_reason =
        absl::StrCat("usable, but ", DeviceTypeName(c.type), " ranks below ",
                     DeviceTypeName(candidates[best].type), " \"", candidates[best].name, "\"");
    if (DeviceTypeRank(c.type) == DeviceTypeRank(candidates[best].type)) {
      c.reject_reason = absl::StrCat("usable, but enumerated after \"", candidates[best].name,
                                     "\" of the same type");
    }
  }
  return static_cast<size_t>(best);
}

absl::StatusOr<DeviceCandidate> SelectPhysicalDevice(VkInstance instance, std::string_view pin) {
  uint32_t count = 0;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkEnumeratePhysicalDevices(instance, &count, nullptr));
  std::vector<VkPhysicalDevice> devices(count);
  IMPOSTOR_VK_RETURN_IF_ERROR(vkEnumeratePhysicalDevices(instance, &count, devices.data()));
  devices.resize(count);

  std::vector<DeviceCandidate> candidates;
  candidates.reserve(devices.size());
  for (VkPhysicalDevice d : devices) candidates.push_back(InspectPhysicalDevice(d));

  absl::StatusOr<size_t> chosen = ChooseDevice(candidates, pin);
  if (!chosen.ok()) return chosen.status();
  for (size_t i = 0; i < candidates.size(); ++i) {
    const DeviceCandidate& c = candidates[i];
    if (i == *chosen) {
      spdlog::info("vulkan: using device \"{}\" ({}, Vulkan {}, driver {}){}", c.name,
                   DeviceTypeName(c.type), ApiVersionString(c.api_version), c.driver,
                   pin.empty() ? "" : absl::StrCat(", pinned by \"", std::string(pin), "\""));
    } else {
      spdlog::info("vulkan: skipped device \"{}\" ({}): {}", c.name, DeviceTypeName(c.type),
                   c.reject_reason);
    }
  }
  return candidates[*chosen];
}

}  // namespace impostor::gpu
