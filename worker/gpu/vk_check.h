// VkResult -> absl::Status. Every Vulkan call that can fail goes through
// VkCheck so the status names the call that failed, e.g.
//   "vkAllocateMemory: VK_ERROR_OUT_OF_DEVICE_MEMORY".
// Out-of-memory results become RESOURCE_EXHAUSTED (the caller may retry with
// a smaller atlas or on another worker); a lost device or missing driver
// support UNAVAILABLE; anything else INTERNAL.
#ifndef IMPOSTOR_WORKER_GPU_VK_CHECK_H_
#define IMPOSTOR_WORKER_GPU_VK_CHECK_H_

#include <vulkan/vulkan.h>

#include <utility>

#include "absl/status/status.h"

namespace impostor::gpu {

// "VK_ERROR_DEVICE_LOST", or "VkResult(<n>)" for values this build does not
// know.
const char* VkResultName(VkResult result);

// OK for VK_SUCCESS (and the other non-error codes); otherwise a status whose
// message starts with `call`.
absl::Status VkCheck(VkResult result, const char* call);

}  // namespace impostor::gpu

// Evaluates a Vulkan call once and returns its status from the enclosing
// function on failure. `call` is stringised up to the argument list, so the
// message names the function: IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateImage(...)).
#define IMPOSTOR_VK_RETURN_IF_ERROR(expr)                                          \
  do {                                                                             \
    const VkResult impostor_vk_result_ = (expr);                                   \
    if (impostor_vk_result_ < 0) {                                                 \
      return ::impostor::gpu::VkCheck(impostor_vk_result_,                         \
                                      ::impostor::gpu::internal::CallName(#expr)); \
    }                                                                              \
  } while (false)

// Propagates a non-OK absl::Status.
#define IMPOSTOR_GPU_RETURN_IF_ERROR(expr)               \
  do {                                                   \
    ::absl::Status impostor_status_ = (expr);            \
    if (!impostor_status_.ok()) return impostor_status_; \
  } while (false)

#define IMPOSTOR_GPU_CONCAT_INNER_(a, b) a##b
#define IMPOSTOR_GPU_CONCAT_(a, b) IMPOSTOR_GPU_CONCAT_INNER_(a, b)
// `lhs = value of a StatusOr<T> expression`, returning its status on error.
#define IMPOSTOR_GPU_ASSIGN_OR_RETURN(lhs, expr) \
  IMPOSTOR_GPU_ASSIGN_OR_RETURN_IMPL_(IMPOSTOR_GPU_CONCAT_(impostor_statusor_, __LINE__), lhs, expr)
#define IMPOSTOR_GPU_ASSIGN_OR_RETURN_IMPL_(tmp, lhs, expr) \
  auto tmp = (expr);                                        \
  if (!tmp.ok()) return tmp.status();                       \
  lhs = std::move(tmp).value()

namespace impostor::gpu::internal {
// "vkCreateImage(device, &info, nullptr, &image)" -> "vkCreateImage". Returns
// a pointer into a thread-local buffer, valid until the next call.
const char* CallName(const char* expression);
}  // namespace impostor::gpu::internal

#endif  // IMPOSTOR_WORKER_GPU_VK_CHECK_H_
