#include "worker/gpu/vulkan_context.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "worker/gpu/device_selection.h"
#include "worker/gpu/vk_check.h"

namespace impostor::gpu {
namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";

bool HasLayer(const char* name) {
  uint32_t count = 0;
  if (vkEnumerateInstanceLayerProperties(&count, nullptr) != VK_SUCCESS) return false;
  std::vector<VkLayerProperties> layers(count);
  if (vkEnumerateInstanceLayerProperties(&count, layers.data()) < 0) return false;
  for (uint32_t i = 0; i < count; ++i) {
    if (std::strcmp(layers[i].layerName, name) == 0) return true;
  }
  return false;
}

bool HasInstanceExtension(const char* name) {
  uint32_t count = 0;
  if (vkEnumerateInstanceExtensionProperties(nullptr, &count, nullptr) != VK_SUCCESS) return false;
  std::vector<VkExtensionProperties> extensions(count);
  if (vkEnumerateInstanceExtensionProperties(nullptr, &count, extensions.data()) < 0) return false;
  for (uint32_t i = 0; i < count; ++i) {
    if (std::strcmp(extensions[i].extensionName, name) == 0) return true;
  }
  return false;
}

VKAPI_ATTR VkBool32 VKAPI_CALL OnValidationMessage(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                   VkDebugUtilsMessageTypeFlagsEXT,
                                                   const VkDebugUtilsMessengerCallbackDataEXT* data,
                                                   void*) {
  const char* message = data != nullptr && data->pMessage != nullptr ? data->pMessage : "";
  if (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) {
    spdlog::error("vulkan validation: {}", message);
  } else if (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) {
    spdlog::warn("vulkan validation: {}", message);
  } else {
    spdlog::debug("vulkan validation: {}", message);
  }
  return VK_FALSE;  // never abort the call
}

}  // namespace

absl::StatusOr<std::unique_ptr<VulkanContext>> VulkanContext::Create(
    const std::string& preferred_device) {
  std::unique_ptr<VulkanContext> ctx(new VulkanContext());

  uint32_t loader_version = VK_API_VERSION_1_0;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkEnumerateInstanceVersion(&loader_version));
  if (loader_version < VK_API_VERSION_1_3) {
    return absl::UnavailableError(
        absl::StrCat("Vulkan loader supports ", VK_API_VERSION_MAJOR(loader_version), ".",
                     VK_API_VERSION_MINOR(loader_version), ", the baker needs 1.3"));
  }

  std::vector<const char*> layers;
  std::vector<const char*> extensions;
  const char* validation_env = std::getenv("IMPOSTOR_VK_VALIDATION");
  const bool want_validation = validation_env != nullptr && std::string(validation_env) == "1";
  if (want_validation) {
    if (HasLayer(kValidationLayer)) {
      layers.push_back(kValidationLayer);
    } else {
      spdlog::warn("vulkan: IMPOSTOR_VK_VALIDATION=1 but {} is not installed", kValidationLayer);
    }
  }
  const bool debug_utils = HasInstanceExtension(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  if (debug_utils) extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);

  VkApplicationInfo app{};
  app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
  app.pApplicationName = "impostor-bake-worker";
  app.pEngineName = "impostor";
  app.apiVersion = VK_API_VERSION_1_3;
  VkInstanceCreateInfo instance_info{};
  instance_info.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
  instance_info.pApplicationInfo = &app;
  instance_info.enabledLayerCount = static_cast<uint32_t>(layers.size());
  instance_info.ppEnabledLayerNames = layers.data();
  instance_info.enabledExtensionCount = static_cast<uint32_t>(extensions.size());
  instance_info.ppEnabledExtensionNames = extensions.data();
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateInstance(&instance_info, nullptr, &ctx->instance_));

  if (debug_utils) {
    ctx->set_object_name_ = reinterpret_cast<PFN_vkSetDebugUtilsObjectNameEXT>(
        vkGetInstanceProcAddr(ctx->instance_, "vkSetDebugUtilsObjectNameEXT"));
    if (!layers.empty()) {
      auto create_messenger = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
          vkGetInstanceProcAddr(ctx->instance_, "vkCreateDebugUtilsMessengerEXT"));
      ctx->destroy_messenger_ = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
          vkGetInstanceProcAddr(ctx->instance_, "vkDestroyDebugUtilsMessengerEXT"));
      if (create_messenger != nullptr && ctx->destroy_messenger_ != nullptr) {
        VkDebugUtilsMessengerCreateInfoEXT info{};
        info.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT;
        info.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
                               VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
        info.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                           VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                           VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
        info.pfnUserCallback = OnValidationMessage;
        IMPOSTOR_VK_RETURN_IF_ERROR(
            create_messenger(ctx->instance_, &info, nullptr, &ctx->messenger_));
      }
    }
  }

  std::string pin = preferred_device;
  if (pin.empty()) {
    const char* env_pin = std::getenv("IMPOSTOR_VK_DEVICE");
    if (env_pin != nullptr) pin = env_pin;
  }
  absl::StatusOr<DeviceCandidate> chosen = SelectPhysicalDevice(ctx->instance_, pin);
  if (!chosen.ok()) return chosen.status();
  ctx->physical_device_ = chosen->handle;
  ctx->queue_family_ = chosen->graphics_queue_family;
  vkGetPhysicalDeviceProperties(ctx->physical_device_, &ctx->properties_);
  {
    // Both structs are core on the 1.3 devices SelectPhysicalDevice accepts.
    VkPhysicalDeviceMaintenance4Properties maintenance4{};
    maintenance4.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_4_PROPERTIES;
    VkPhysicalDeviceMaintenance3Properties maintenance3{};
    maintenance3.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES;
    maintenance3.pNext = &maintenance4;
    VkPhysicalDeviceProperties2 props2{};
    props2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
    props2.pNext = &maintenance3;
    vkGetPhysicalDeviceProperties2(ctx->physical_device_, &props2);
    ctx->max_allocation_size_ = maintenance3.maxMemoryAllocationSize;
    ctx->max_buffer_size_ = maintenance4.maxBufferSize;
    spdlog::debug("gpu: largest allocation {} bytes, largest buffer {} bytes",
                  ctx->max_allocation_size_, ctx->max_buffer_size_);
  }
  vkGetPhysicalDeviceMemoryProperties(ctx->physical_device_, &ctx->memory_properties_);
  ctx->info_.name = chosen->name;
  ctx->info_.type = DeviceTypeName(chosen->type);
  ctx->info_.api_version = chosen->api_version;
  ctx->info_.driver = chosen->driver;
  ctx->info_.max_allocation_bytes = static_cast<int64_t>(ctx->max_allocation_size_);
  for (uint32_t i = 0; i < ctx->memory_properties_.memoryHeapCount; ++i) {
    const VkMemoryHeap& heap = ctx->memory_properties_.memoryHeaps[i];
    if (heap.flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT) {
      ctx->info_.device_local_heap_bytes =
          std::max(ctx->info_.device_local_heap_bytes, static_cast<int64_t>(heap.size));
    }
  }

  VkPhysicalDeviceFeatures supported{};
  vkGetPhysicalDeviceFeatures(ctx->physical_device_, &supported);
  VkPhysicalDeviceVulkan13Features features13{};
  features13.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES;
  features13.dynamicRendering = VK_TRUE;
  features13.synchronization2 = VK_TRUE;
  VkPhysicalDeviceFeatures2 features{};
  features.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
  features.pNext = &features13;
  // Optional: sharper oblique texture sampling, and index values above 2^24.
  // Not on a CPU device: lavapipe's anisotropic filtering costs in
  // proportion to the footprint, and a texture repeated thousands of times
  // (or KHR_mesh_quantization's unnormalised texcoords) made a one-sample
  // render of 72 small views take 20-70 s instead of 0.3 s. Only one-sample
  // renders would use it (supersampled ones filter by mip level alone).
  const bool cpu_device = ctx->properties_.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
  features.features.samplerAnisotropy = supported.samplerAnisotropy && !cpu_device;
  features.features.fullDrawIndexUint32 = supported.fullDrawIndexUint32;
  if (features.features.samplerAnisotropy) {
    ctx->max_anisotropy_ = std::min(8.0f, ctx->properties_.limits.maxSamplerAnisotropy);
  }

  const float priority = 1.0f;
  VkDeviceQueueCreateInfo queue_info{};
  queue_info.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
  queue_info.queueFamilyIndex = ctx->queue_family_;
  queue_info.queueCount = 1;
  queue_info.pQueuePriorities = &priority;
  VkDeviceCreateInfo device_info{};
  device_info.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
  device_info.pNext = &features;
  device_info.queueCreateInfoCount = 1;
  device_info.pQueueCreateInfos = &queue_info;
  IMPOSTOR_VK_RETURN_IF_ERROR(
      vkCreateDevice(ctx->physical_device_, &device_info, nullptr, &ctx->device_));
  vkGetDeviceQueue(ctx->device_, ctx->queue_family_, 0, &ctx->queue_);
  return ctx;
}

VulkanContext::~VulkanContext() {
  if (device_ != VK_NULL_HANDLE) {
    // Nothing may be destroyed while the GPU still uses it; the result is
    // irrelevant here (a lost device is idle too).
    vkDeviceWaitIdle(device_);
    vkDestroyDevice(device_, nullptr);
  }
  if (messenger_ != VK_NULL_HANDLE && destroy_messenger_ != nullptr) {
    destroy_messenger_(instance_, messenger_, nullptr);
  }
  if (instance_ != VK_NULL_HANDLE) vkDestroyInstance(instance_, nullptr);
}

void VulkanContext::SetName(VkObjectType type, uint64_t handle, const char* name) const {
  if (set_object_name_ == nullptr || device_ == VK_NULL_HANDLE) return;
  VkDebugUtilsObjectNameInfoEXT info{};
  info.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_OBJECT_NAME_INFO_EXT;
  info.objectType = type;
  info.objectHandle = handle;
  info.pObjectName = name;
  set_object_name_(device_, &info);  // best effort: a name never fails a bake
}

}  // namespace impostor::gpu
