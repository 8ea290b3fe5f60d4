// A VkBuffer with its own memory. Host-visible buffers stay mapped for their
// whole life. Move-only; destroying it frees the buffer, then the memory, so
// the owner must know the GPU is done with it (fence waited).
// Thread-safety: none.
#ifndef IMPOSTOR_WORKER_GPU_GPU_BUFFER_H_
#define IMPOSTOR_WORKER_GPU_GPU_BUFFER_H_

#include <vulkan/vulkan.h>

#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "worker/gpu/vk_handle.h"
#include "worker/gpu/vulkan_context.h"

namespace impostor::gpu {

class GpuBuffer {
 public:
  // `required` memory flags must be met; `preferred` ones are taken when some
  // memory type has them (e.g. HOST_CACHED for readback).
  static absl::StatusOr<GpuBuffer> Create(const VulkanContext& ctx, VkDeviceSize size,
                                          VkBufferUsageFlags usage, VkMemoryPropertyFlags required,
                                          VkMemoryPropertyFlags preferred, const std::string& name);

  GpuBuffer() = default;
  GpuBuffer(GpuBuffer&&) noexcept = default;
  GpuBuffer& operator=(GpuBuffer&&) noexcept = default;

  VkBuffer buffer() const { return buffer_.get(); }
  VkDeviceSize size() const { return size_; }
  // Non-null for host-visible buffers.
  void* mapped() const { return mapped_; }

  // On non-coherent memory, makes host writes visible to the device (call
  // before submitting) or device writes visible to the host (call after the
  // fence). No-ops on coherent memory.
  absl::Status FlushHostWrites() const;
  absl::Status InvalidateForHostRead() const;

 private:
  VkDevice device_ = VK_NULL_HANDLE;
  // Declared before buffer_ so the buffer is destroyed first.
  UniqueMemory memory_;
  UniqueBuffer buffer_;
  VkDeviceSize size_ = 0;
  void* mapped_ = nullptr;
  bool coherent_ = true;
};

}  // namespace impostor::gpu

#endif  // IMPOSTOR_WORKER_GPU_GPU_BUFFER_H_
