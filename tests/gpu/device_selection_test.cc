// Device ranking and pinning, without touching a real device.
#include "worker/gpu/device_selection.h"

#include <gtest/gtest.h>

#include <vector>

namespace impostor::gpu {
namespace {

DeviceCandidate Make(const char* name, VkPhysicalDeviceType type, const char* reject = "") {
  DeviceCandidate c;
  c.name = name;
  c.type = type;
  c.api_version = VK_API_VERSION_1_3;
  c.reject_reason = reject;
  return c;
}

TEST(ChooseDeviceTest, PrefersDiscreteOverIntegratedOverCpu) {
  std::vector<DeviceCandidate> c = {
      Make("llvmpipe", VK_PHYSICAL_DEVICE_TYPE_CPU),
      Make("Intel UHD", VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU),
      Make("NVIDIA H100", VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU),
      Make("Old GPU", VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU, "supports Vulkan 1.1.0, needs 1.3"),
  };
  absl::StatusOr<size_t> chosen = ChooseDevice(c, "");
  ASSERT_TRUE(chosen.ok()) << chosen.status();
  EXPECT_EQ(*chosen, 2u);
  EXPECT_TRUE(c[2].reject_reason.empty());
  EXPECT_NE(c[0].reject_reason.find("ranks below"), std::string::npos) << c[0].reject_reason;
  EXPECT_NE(c[1].reject_reason.find("ranks below"), std::string::npos) << c[1].reject_reason;
  EXPECT_EQ(c[3].reject_reason, "supports Vulkan 1.1.0, needs 1.3");
}

TEST(ChooseDeviceTest, TiesKeepEnumerationOrder) {
  std::vector<DeviceCandidate> c = {Make("GPU A", VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU),
                                    Make("GPU B", VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU)};
  absl::StatusOr<size_t> chosen = ChooseDevice(c, "");
  ASSERT_TRUE(chosen.ok());
  EXPECT_EQ(*chosen, 0u);
  EXPECT_NE(c[1].reject_reason.find("enumerated after"), std::string::npos);
}

TEST(ChooseDeviceTest, PinIsCaseInsensitiveSubstringAndBeatsRank) {
  std::vector<DeviceCandidate> c = {Make("NVIDIA H100", VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU),
                                    Make("llvmpipe (LLVM 15)", VK_PHYSICAL_DEVICE_TYPE_CPU)};
  absl::StatusOr<size_t> chosen = ChooseDevice(c, "LLVMpipe");
  ASSERT_TRUE(chosen.ok());
  EXPECT_EQ(*chosen, 1u);
  EXPECT_NE(c[0].reject_reason.find("pinned"), std::string::npos);
}

TEST(ChooseDeviceTest, NothingUsableIsUnavailableAndListsReasons) {
  std::vector<DeviceCandidate> c = {
      Make("Old GPU", VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU, "no dynamicRendering")};
  absl::StatusOr<size_t> chosen = ChooseDevice(c, "");
  ASSERT_FALSE(chosen.ok());
  EXPECT_EQ(chosen.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_NE(chosen.status().message().find("Old GPU: no dynamicRendering"), std::string::npos);

  std::vector<DeviceCandidate> none;
  EXPECT_EQ(ChooseDevice(none, "").status().code(), absl::StatusCode::kUnavailable);

  std::vector<DeviceCandidate> unmatched = {Make("llvmpipe", VK_PHYSICAL_DEVICE_TYPE_CPU)};
  EXPECT_EQ(ChooseDevice(unmatched, "radeon").status().code(), absl::StatusCode::kUnavailable);
}

}  // namespace
}  // namespace impostor::gpu
