// The Vulkan instance, the chosen physical device, the logical device and
// its graphics queue: everything that lives as long as an AtlasRenderer.
//
// Ownership: owns the instance, the optional validation messenger and the
// device, and destroys them (device first) after waiting for the device to
// go idle. Objects created from the device must be destroyed before the
// context; AtlasRendererVulkan declares it as its first member for that.
// Thread-safety: none; one thread uses a context (and its queue) at a time.
#ifndef IMPOSTOR_WORKER_GPU_VULKAN_CONTEXT_H_
#define IMPOSTOR_WORKER_GPU_VULKAN_CONTEXT_H_

#include <vulkan/vulkan.h>

#include <cstdint>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "worker/gpu/atlas_renderer.h"

namespace impostor::gpu {

class VulkanContext {
 public:
  // `preferred_device` (substring of a device name) pins a device; when
  // empty, env IMPOSTOR_VK_DEVICE does. Env IMPOSTOR_VK_VALIDATION=1 enables
  // VK_LAYER_KHRONOS_validation when installed (a warning if not).
  static absl::StatusOr<std::unique_ptr<VulkanContext>> Create(const std::string& preferred_device);
  ~VulkanContext();

  VulkanContext(const VulkanContext&) = delete;
  VulkanContext& operator=(const VulkanContext&) = delete;

  VkInstance instance() const { return instance_; }
  VkPhysicalDevice physical_device() const { return physical_device_; }
  VkDevice device() const { return device_; }
  VkQueue queue() const { return queue_; }
  uint32_t queue_family() const { return queue_family_; }
  const VkPhysicalDeviceLimits& limits() const { return properties_.limits; }
  const VkPhysicalDeviceMemoryProperties& memory_properties() const { return memory_properties_; }
  const DeviceInfo& info() const { return info_; }
  // 0 when the device has no anisotropic filtering.
  float max_anisotropy() const { return max_anisotropy_; }
  // The largest single VkDeviceMemory allocation the device promises
  // (VkPhysicalDeviceMaintenance3Properties::maxMemoryAllocationSize, e.g.
  // 2 GiB on lavapipe), and the largest VkBuffer
  // (VkPhysicalDeviceMaintenance4Properties::maxBufferSize). Every buffer and
  // image is checked against them before it is created (gpu_memory.h).
  VkDeviceSize max_allocation_size() const { return max_allocation_size_; }
  VkDeviceSize max_buffer_size() const { return max_buffer_size_; }
  // Tests only: pretends the device allows at most `bytes` per allocation
  // and per buffer, so a small scene exercises the over-the-limit path.
  void SetMaxAllocationSizeForTesting(VkDeviceSize bytes) {
    max_allocation_size_ = bytes;
    max_buffer_size_ = bytes;
  }

  // Labels an object for debuggers and validation messages; a no-op unless
  // VK_EXT_debug_utils is present.
  void SetName(VkObjectType type, uint64_t handle, const char* name) const;
  template <typename Handle>
  void SetName(VkObjectType type, Handle handle, const std::string& name) const {
    SetName(type, reinterpret_cast<uint64_t>(handle), name.c_str());
  }

 private:
  VulkanContext() = default;

  VkInstance instance_ = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
  VkPhysicalDevice physical_device_ = VK_NULL_HANDLE;
  VkDevice device_ = VK_NULL_HANDLE;
  VkQueue queue_ = VK_NULL_HANDLE;
  uint32_t queue_family_ = 0;
  VkPhysicalDeviceProperties properties_{};
  VkPhysicalDeviceMemoryProperties memory_properties_{};
  DeviceInfo info_;
  float max_anisotropy_ = 0.0f;
  VkDeviceSize max_allocation_size_ = 0;
  VkDeviceSize max_buffer_size_ = 0;
  PFN_vkSetDebugUtilsObjectNameEXT set_object_name_ = nullptr;
  PFN_vkDestroyDebugUtilsMessengerEXT destroy_messenger_ = nullptr;
};

}  // namespace impostor::gpu

#endif  // IMPOSTOR_WORKER_GPU_VULKAN_CONTEXT_H_
