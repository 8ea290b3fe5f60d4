#include "worker/gpu/command_runner.h"

#include <cstdint>
#include <utility>

#include "worker/gpu/vk_check.h"

namespace impostor::gpu {

absl::StatusOr<CommandRunner> CommandRunner::Create(const VulkanContext& ctx) {
  CommandRunner out;
  out.device_ = ctx.device();
  out.queue_ = ctx.queue();

  VkCommandPoolCreateInfo pool_info{};
  pool_info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
  pool_info.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
  pool_info.queueFamilyIndex = ctx.queue_family();
  VkCommandPool pool = VK_NULL_HANDLE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateCommandPool(out.device_, &pool_info, nullptr, &pool));
  out.pool_ = UniqueCommandPool(out.device_, pool);

  VkCommandBufferAllocateInfo alloc{};
  alloc.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
  alloc.commandPool = pool;
  alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  alloc.commandBufferCount = 1;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkAllocateCommandBuffers(out.device_, &alloc, &out.buffer_));

  VkFenceCreateInfo fence_info{};
  fence_info.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
  VkFence fence = VK_NULL_HANDLE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateFence(out.device_, &fence_info, nullptr, &fence));
  out.fence_ = UniqueFence(out.device_, fence);
  return out;
}

CommandRunner::CommandRunner(CommandRunner&& other) noexcept
    : device_(other.device_),
      queue_(other.queue_),
      pool_(std::move(other.pool_)),
      fence_(std::move(other.fence_)),
      buffer_(std::exchange(other.buffer_, VK_NULL_HANDLE)),
      recording_(std::exchange(other.recording_, false)),
      in_flight_(std::exchange(other.in_flight_, false)) {}

CommandRunner& CommandRunner::operator=(CommandRunner&& other) noexcept {
  if (this != &other) {
    WaitIfInFlight();
    device_ = other.device_;
    queue_ = other.queue_;
    fence_ = std::move(other.fence_);
    pool_ = std::move(other.pool_);
    buffer_ = std::exchange(other.buffer_, VK_NULL_HANDLE);
    recording_ = std::exchange(other.recording_, false);
    in_flight_ = std::exchange(other.in_flight_, false);
  }
  return *this;
}

CommandRunner::~CommandRunner() { WaitIfInFlight(); }

void CommandRunner::WaitIfInFlight() {
  if (in_flight_ && fence_) {
    // Best effort: on a lost device this returns at once, and the device is
    // idle by definition.
    const VkFence fence = fence_.get();
    vkWaitForFences(device_, 1, &fence, VK_TRUE, UINT64_MAX);
  }
  in_flight_ = false;
}

absl::StatusOr<VkCommandBuffer> CommandRunner::Begin() {
  WaitIfInFlight();
  IMPOSTOR_VK_RETURN_IF_ERROR(vkResetCommandPool(device_, pool_.get(), 0));
  VkCommandBufferBeginInfo begin{};
  begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkBeginCommandBuffer(buffer_, &begin));
  recording_ = true;
  return buffer_;
}

absl::Status CommandRunner::SubmitAndWait() {
  recording_ = false;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkEndCommandBuffer(buffer_));
  const VkFence fence = fence_.get();
  IMPOSTOR_VK_RETURN_IF_ERROR(vkResetFences(device_, 1, &fence));

  VkCommandBufferSubmitInfo buffer_info{};
  buffer_info.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO;
  buffer_info.commandBuffer = buffer_;
  VkSubmitInfo2 submit{};
  submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO_2;
  submit.commandBufferInfoCount = 1;
  submit.pCommandBufferInfos = &buffer_info;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkQueueSubmit2(queue_, 1, &submit, fence));
  in_flight_ = true;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkWaitForFences(device_, 1, &fence, VK_TRUE, UINT64_MAX));
  in_flight_ = false;
  return absl::OkStatus();
}

}  // namespace impostor::gpu
