#include "worker/gpu/vk_check.h"

#include <cstring>
#include <string>

#include "absl/strings/str_cat.h"

namespace impostor::gpu {

const char* VkResultName(VkResult result) {
  switch (result) {
#define IMPOSTOR_VK_RESULT_CASE(name) \
  case name:                          \
    return #name;
    IMPOSTOR_VK_RESULT_CASE(VK_SUCCESS)
    IMPOSTOR_VK_RESULT_CASE(VK_NOT_READY)
    IMPOSTOR_VK_RESULT_CASE(VK_TIMEOUT)
    IMPOSTOR_VK_RESULT_CASE(VK_EVENT_SET)
    IMPOSTOR_VK_RESULT_CASE(VK_EVENT_RESET)
    IMPOSTOR_VK_RESULT_CASE(VK_INCOMPLETE)
    IMPOSTOR_VK_RESULT_CASE(VK_ERROR_OUT_OF_HOST_MEMORY)
    IMPOSTOR_VK_RESULT_CASE(VK_ERROR_OUT_OF_DEVICE_MEMORY)
    IMPOSTOR_VK_RESULT_CASE(VK_ERROR_INITIALIZATION_FAILED)
    IMPOSTOR_VK_RESULT_CASE(VK_ERROR_DEVICE_LOST)
    IMPOSTOR_VK_RESULT_CASE(VK_ERROR_MEMORY_MAP_FAILED)
    IMPOSTOR_VK_RESULT_CASE(VK_ERROR_LAYER_NOT_PRESENT)
    IMPOSTOR_VK_RESULT_CASE(VK_ERROR_EXTENSION_NOT_PRESENT)
    IMPOSTOR_VK_RESULT_CASE(VK_ERROR_FEATURE_NOT_PRESENT)
    IMPOSTOR_VK_RESULT_CASE(VK_ERROR_INCOMPATIBLE_DRIVER)
    IMPOSTOR_VK_RESULT_CASE(VK_ERROR_TOO_MANY_OBJECTS)
    IMPOSTOR_VK_RESULT_CASE(VK_ERROR_FORMAT_NOT_SUPPORTED)
    IMPOSTOR_VK_RESULT_CASE(VK_ERROR_FRAGMENTED_POOL)
    IMPOSTOR_VK_RESULT_CASE(VK_ERROR_UNKNOWN)
    IMPOSTOR_VK_RESULT_CASE(VK_ERROR_OUT_OF_POOL_MEMORY)
    IMPOSTOR_VK_RESULT_CASE(VK_ERROR_INVALID_EXTERNAL_HANDLE)
    IMPOSTOR_VK_RESULT_CASE(VK_ERROR_FRAGMENTATION)
    IMPOSTOR_VK_RESULT_CASE(VK_ERROR_INVALID_OPAQUE_CAPTURE_ADDRESS)
    IMPOSTOR_VK_RESULT_CASE(VK_PIPELINE_COMPILE_REQUIRED)
#undef IMPOSTOR_VK_RESULT_CASE
    default:
      return nullptr;
  }
}

absl::Status VkCheck(VkResult result, const char* call) {
  if (result >= 0) return absl::OkStatus();
  const char* name = VkResultName(result);
  const std::string message =
      name != nullptr ? absl::StrCat(call, ": ", name)
                      : absl::StrCat(call, ": VkResult(", static_cast<int>(result), ")");
  switch (result) {
    case VK_ERROR_OUT_OF_HOST_MEMORY:
    case VK_ERROR_OUT_OF_DEVICE_MEMORY:
    case VK_ERROR_OUT_OF_POOL_MEMORY:
    case VK_ERROR_FRAGMENTED_POOL:
    case VK_ERROR_FRAGMENTATION:
    case VK_ERROR_TOO_MANY_OBJECTS:
      return absl::ResourceExhaustedError(message);
    case VK_ERROR_DEVICE_LOST:
    case VK_ERROR_INITIALIZATION_FAILED:
    case VK_ERROR_INCOMPATIBLE_DRIVER:
    case VK_ERROR_LAYER_NOT_PRESENT:
    case VK_ERROR_EXTENSION_NOT_PRESENT:
    case VK_ERROR_FEATURE_NOT_PRESENT:
    case VK_ERROR_FORMAT_NOT_SUPPORTED:
      return absl::UnavailableError(message);
    default:
      return absl::InternalError(message);
  }
}

namespace internal {

const char* CallName(const char* expression) {
  thread_local std::string name;
  const char* paren = std::strchr(expression, '(');
  name.assign(expression, paren != nullptr ? paren - expression : std::strlen(expression));
  // Trim whitespace left by the preprocessor ("vkFoo (" is legal).
  while (!name.empty() && name.back() == ' ') name.pop_back();
  return name.c_str();
}

}  // namespace internal
}  // namespace impostor::gpu
