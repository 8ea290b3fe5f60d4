// One command pool, one primary command buffer and one fence: record a batch
// of work, submit it and wait for it. The baker's GPU work is a sequence of
// such batches (uploads, render chunks, readback), each waited on before the
// next is recorded, so one buffer suffices and nothing is ever destroyed
// while in flight.
//
// Ownership: owns the pool (and so the buffer) and the fence; the destructor
// waits for a submission still in flight. Thread-safety: none.
#ifndef IMPOSTOR_WORKER_GPU_COMMAND_RUNNER_H_
#define IMPOSTOR_WORKER_GPU_COMMAND_RUNNER_H_

#include <vulkan/vulkan.h>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "worker/gpu/vk_handle.h"
#include "worker/gpu/vulkan_context.h"

namespace impostor::gpu {

class CommandRunner {
 public:
  static absl::StatusOr<CommandRunner> Create(const VulkanContext& ctx);

  CommandRunner() = default;
  CommandRunner(CommandRunner&& other) noexcept;
  CommandRunner& operator=(CommandRunner&& other) noexcept;
  ~CommandRunner();

  // Resets the buffer and starts recording (one-time submit).
  absl::StatusOr<VkCommandBuffer> Begin();
  bool recording() const { return recording_; }
  // The buffer being recorded (valid between Begin() and SubmitAndWait()).
  VkCommandBuffer buffer() const { return buffer_; }
  // Ends recording, submits to the context's queue and blocks until the GPU
  // finishes. The wait has no timeout: a hung GPU surfaces as
  // VK_ERROR_DEVICE_LOST from the driver, and giving up earlier would leave
  // resources in use that the caller is about to free.
  absl::Status SubmitAndWait();

 private:
  void WaitIfInFlight();

  VkDevice device_ = VK_NULL_HANDLE;
  VkQueue queue_ = VK_NULL_HANDLE;
  UniqueCommandPool pool_;
  UniqueFence fence_;
  VkCommandBuffer buffer_ = VK_NULL_HANDLE;  // freed with pool_
  bool recording_ = false;
  bool in_flight_ = false;
};

}  // namespace impostor::gpu

#endif  // IMPOSTOR_WORKER_GPU_COMMAND_RUNNER_H_
