// Buffers and images are checked against the device's largest allocation
// (and buffer, and storage range) before they are created
// (worker/gpu/gpu_memory.h). A few-KB glTF instancing a mesh 100,000 times
// flattened to a 2.16 GB vertex buffer; lavapipe allows 2 GiB per
// allocation and segfaulted in memcpy instead of failing the bake.
#include <gtest/gtest.h>

#include <string>

#include "worker/gpu/bake_pipeline.h"
#include "worker/gpu/command_runner.h"
#include "worker/gpu/gpu_buffer.h"
#include "worker/gpu/gpu_memory.h"
#include "worker/gpu/scene_resources.h"
#include "worker/gpu/vulkan_context.h"
#include "worker/scene/scene.h"

namespace impostor::gpu {
namespace {

TEST(DeviceLimits, CheckNamesWhatIsTooLargeAndTheLimit) {
  const absl::Status s =
      CheckDeviceLimit("vertex buffer", 2160000000ull, "30000000 vertices after instancing",
                       2147483648ull, "largest allocation", "llvmpipe (LLVM 15)");
  EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted);
  EXPECT_EQ(s.message(),
            "vertex buffer: 2160000000 bytes (30000000 vertices after instancing) is over the "
            "device's largest allocation, 2147483648 bytes (llvmpipe (LLVM 15))");
  EXPECT_EQ(CheckDeviceLimit("x", 5, "", 4, "largest buffer", "dev").message(),
            "x: 5 bytes is over the device's largest buffer, 4 bytes (dev)");
}

TEST(DeviceLimits, SizesUpToTheLimitPass) {
  EXPECT_TRUE(CheckDeviceLimit("x", 2147483648ull, "", 2147483648ull, "l", "d").ok());
  EXPECT_TRUE(CheckDeviceLimit("x", 0, "", 1, "l", "d").ok());
  // 0: the device states no limit.
  EXPECT_TRUE(CheckDeviceLimit("x", ~0ull, "", 0, "l", "d").ok());
}

TEST(DeviceLimits, ContextReadsTheDevicesLimits) {
  auto ctx = VulkanContext::Create("");
  if (!ctx.ok()) GTEST_SKIP() << "no Vulkan device: " << ctx.status();
  // The spec's minimums: 1 GiB for both.
  EXPECT_GE((*ctx)->max_allocation_size(), VkDeviceSize{1} << 30);
  EXPECT_GE((*ctx)->max_buffer_size(), VkDeviceSize{1} << 30);
  // The same figures, and the largest device-local heap, as the renderer
  // reports them to the worker's memory check (gpu/device_memory_limits.h).
  EXPECT_EQ((*ctx)->info().max_allocation_bytes, static_cast<int64_t>((*ctx)->max_allocation_size()));
  EXPECT_GT((*ctx)->info().device_local_heap_bytes, 0);
  // One byte over the device's largest allocation is refused before Vulkan
  // sees it (no memory is touched).
  const VkDeviceSize over = (*ctx)->max_allocation_size() + 1;
  const absl::Status s = CheckBufferFits(**ctx, "vertex buffer", over,
                                         VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, "n vertices");
  EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted);
  EXPECT_NE(s.message().find("is over the device's largest allocation"), std::string::npos)
      << s.message();
  EXPECT_NE(s.message().find((*ctx)->info().name), std::string::npos) << s.message();
  // So is a buffer the driver would be asked to create directly.
  auto buffer = GpuBuffer::Create(**ctx, over, VK_BUFFER_USAGE_VERTEX_BUFFER_BIT,
                                  VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT, 0, "huge");
  ASSERT_FALSE(buffer.ok());
  EXPECT_EQ(buffer.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_EQ(buffer.status().message().rfind("huge: ", 0), 0u) << buffer.status().message();
}

Scene SmallScene(int vertex_count) {
  Scene scene;
  scene.vertices.resize(vertex_count);
  for (int i = 0; i < vertex_count / 3 * 3; ++i) scene.indices.push_back(i);
  scene.materials.emplace_back();
  return scene;
}

struct Device {
  std::unique_ptr<VulkanContext> ctx;
  CommandRunner runner;
  BakePipeline pipeline;
};

absl::StatusOr<Device> MakeDevice() {
  auto ctx = VulkanContext::Create("");
  if (!ctx.ok()) return ctx.status();
  auto runner = CommandRunner::Create(**ctx);
  if (!runner.ok()) return runner.status();
  auto pipeline = BakePipeline::Create(**ctx);
  if (!pipeline.ok()) return pipeline.status();
  return Device{std::move(*ctx), std::move(*runner), std::move(*pipeline)};
}

TEST(DeviceLimits, UploadRefusesAVertexBufferOverTheLimit) {
  auto dev = MakeDevice();
  if (!dev.ok()) GTEST_SKIP() << "no Vulkan device: " << dev.status();
  const Scene scene = SmallScene(100);  // 7200 bytes of vertices
  // The real limit takes it.
  auto fits = SceneResources::Upload(*dev->ctx, dev->runner, dev->pipeline, scene, TextureFilter{});
  ASSERT_TRUE(fits.ok()) << fits.status();
  fits->reset();

  dev->ctx->SetMaxAllocationSizeForTesting(7199);
  auto refused =
      SceneResources::Upload(*dev->ctx, dev->runner, dev->pipeline, scene, TextureFilter{});
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_EQ(refused.status().message(),
            "vertex buffer: 7200 bytes (100 vertices after instancing) is over the device's "
            "largest allocation, 7199 bytes (" +
                dev->ctx->info().name + ")");

  dev->ctx->SetMaxAllocationSizeForTesting(7200);
  auto at_limit =
      SceneResources::Upload(*dev->ctx, dev->runner, dev->pipeline, scene, TextureFilter{});
  EXPECT_TRUE(at_limit.ok()) << at_limit.status();
}

TEST(DeviceLimits, UploadRefusesATextureOverTheLimit) {
  auto dev = MakeDevice();
  if (!dev.ok()) GTEST_SKIP() << "no Vulkan device: " << dev.status();
  Scene scene = SmallScene(3);
  SceneTexture texture;
  texture.width = 256;
  texture.height = 256;
  texture.rgba8.assign(256 * 256 * 4, 255);
  texture.name = "big.png";
  scene.textures.push_back(texture);
  dev->ctx->SetMaxAllocationSizeForTesting(64 * 1024);  // < 256 KiB of texels
  auto refused =
      SceneResources::Upload(*dev->ctx, dev->runner, dev->pipeline, scene, TextureFilter{});
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_NE(refused.status().message().find("texture 0 big.png"), std::string::npos)
      << refused.status().message();
  EXPECT_NE(refused.status().message().find("largest allocation, 65536 bytes"), std::string::npos)
      << refused.status().message();
}

}  // namespace
}  // namespace impostor::gpu
