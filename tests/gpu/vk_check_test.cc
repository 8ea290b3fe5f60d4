// VkResult -> absl::Status mapping, without a device.
#include "worker/gpu/vk_check.h"

#include <gtest/gtest.h>

namespace impostor::gpu {
namespace {

absl::Status FailingCall() {
  IMPOSTOR_VK_RETURN_IF_ERROR(VK_ERROR_OUT_OF_DEVICE_MEMORY);
  return absl::OkStatus();
}

VkResult vkFakeAllocate(int, int) { return VK_ERROR_OUT_OF_HOST_MEMORY; }

absl::Status NamedCall() {
  IMPOSTOR_VK_RETURN_IF_ERROR(vkFakeAllocate(1, 2));
  return absl::OkStatus();
}

TEST(VkCheckTest, MapsOutOfMemoryToResourceExhausted) {
  const absl::Status s = VkCheck(VK_ERROR_OUT_OF_DEVICE_MEMORY, "vkAllocateMemory");
  EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted);
  EXPECT_EQ(s.message(), "vkAllocateMemory: VK_ERROR_OUT_OF_DEVICE_MEMORY");
  EXPECT_EQ(FailingCall().code(), absl::StatusCode::kResourceExhausted);
}

TEST(VkCheckTest, MacroNamesTheCallWithoutItsArguments) {
  const absl::Status s = NamedCall();
  EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted);
  EXPECT_EQ(s.message(), "vkFakeAllocate: VK_ERROR_OUT_OF_HOST_MEMORY");
}

TEST(VkCheckTest, OtherResults) {
  EXPECT_TRUE(VkCheck(VK_SUCCESS, "x").ok());
  EXPECT_TRUE(VkCheck(VK_INCOMPLETE, "x").ok());  // not an error code
  EXPECT_EQ(VkCheck(VK_ERROR_DEVICE_LOST, "vkQueueSubmit2").code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(VkCheck(VK_ERROR_UNKNOWN, "x").code(), absl::StatusCode::kInternal);
  EXPECT_EQ(VkCheck(static_cast<VkResult>(-12345), "vkFoo").message(), "vkFoo: VkResult(-12345)");
}

}  // namespace
}  // namespace impostor::gpu
