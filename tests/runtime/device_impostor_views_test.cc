// The quality pass's impostor views on the device (worker/gpu/
// device_impostor_views.h) against the CPU reference renderer: many views of
// one uploaded atlas, in batches that share one output buffer, must each be
// the reference renderer's view of the same camera (up to the float ties
// GlslBlend.ShaderViewMatchesTheReferenceRenderer allows), for every
// reconstruction mode, with and without an orm map. Lavapipe suffices.
#include <cmath>
#include <random>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "common/runtime/reference_renderer.h"
#include "tests/runtime/image_compare.h"
#include "tests/runtime/synthetic_atlas.h"
#include "worker/gpu/device_impostor_views.h"
#include "worker/gpu/vulkan_context.h"

namespace impostor {
namespace {

using ::impostor::testing::BakeSyntheticAtlas;
using ::impostor::testing::Compare;
using ::impostor::testing::Comparison;
using ::impostor::testing::CountPixelsBeyond;

// `count` view cameras over the upper hemisphere (the hemi-octahedral
// layout's domain), none on a frame by more than chance.
std::vector<FrameCamera> UpperCameras(int count) {
  std::mt19937 rng(5);
  std::normal_distribution<float> n(0.0f, 1.0f);
  std::vector<FrameCamera> cameras;
  while (static_cast<int>(cameras.size()) < count) {
    glm::vec3 d(n(rng), std::abs(n(rng)) + 0.1f, n(rng));
    cameras.push_back(ViewCameraFor(glm::normalize(d)));
  }
  return cameras;
}

// Each device view against RenderImpostorView of the same camera.
void ExpectViewsMatch(const ImpostorAtlas& atlas, const std::vector<FrameCamera>& cameras,
                      const std::vector<ViewImages>& device, int pixels, const ReferenceRenderOptions& options) {
  ASSERT_EQ(device.size(), cameras.size());
  int covered_views = 0;
  for (size_t i = 0; i < cameras.size(); ++i) {
    const ViewImages cpu = RenderImpostorView(atlas, cameras[i], pixels, options);
    ASSERT_EQ(device[i].width, pixels);
    ASSERT_EQ(device[i].orm.size(), cpu.orm.size());
    const Comparison c = Compare(device[i], cpu);
    if (c.iou > 0.0 && c.coverage_mismatch < pixels * pixels) ++covered_views;
    EXPECT_LE(c.coverage_mismatch, 2) << "view " << i;
    EXPECT_LE(c.albedo_max_diff, 1) << "view " << i;
    EXPECT_LE(c.orm_max_diff, 1) << "view " << i;
    const auto beyond = CountPixelsBeyond(device[i], cpu, 160, 40);
    EXPECT_LE(beyond.normal, 2) << "view " << i;
    EXPECT_LE(beyond.depth, 2) << "view " << i;
  }
  // The object is in every view: a test on empty views could not fail.
  EXPECT_EQ(covered_views, static_cast<int>(cameras.size()));
}

class DeviceImpostorViewsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto ctx = gpu::VulkanContext::Create("");
    // Fails, not skips, without a device (lavapipe is enough): `ctest -LE gpu` opts out.
    ASSERT_TRUE(ctx.ok()) << "no Vulkan device: " << ctx.status();
    ctx_ = std::move(*ctx);
    auto kernel = gpu::ImpostorViewKernel::Create(*ctx_);
    ASSERT_TRUE(kernel.ok()) << kernel.status();
    kernel_ = std::move(*kernel);
  }
  absl::StatusOr<std::unique_ptr<gpu::DeviceImpostorViews>> Upload(const ImpostorAtlas& atlas) const {
    return gpu::DeviceImpostorViews::Create(*ctx_, *kernel_, atlas);
  }
  std::unique_ptr<gpu::VulkanContext> ctx_;
  std::unique_ptr<gpu::ImpostorViewKernel> kernel_;  // destroyed before ctx_
};

// 24 views of 192 px do not fit one batch (gpu::kMaxViewBatchBytes), so the
// second batch reuses the buffer; every view must still be its own camera's.
TEST_F(DeviceImpostorViewsTest, ManyViewsInSeveralBatchesAreEachTheirCamerasView) {
  const ImpostorAtlas atlas = BakeSyntheticAtlas({LayoutKind::kHemiOctahedral, 8, 0}, 512);
  auto views = Upload(atlas);
  ASSERT_TRUE(views.ok()) << views.status();
  constexpr int kPixels = 192;
  ASSERT_GT(24u * kPixels * kPixels * 48, gpu::kMaxViewBatchBytes) << "the test must span batches";
  const std::vector<FrameCamera> cameras = UpperCameras(24);
  const ReferenceRenderOptions plain{.blend = BlendMode::kTriangle3, .reconstruction = Reconstruction::kPlain};
  auto device = (*views)->RenderViews(cameras, kPixels, plain);
  ASSERT_TRUE(device.ok()) << device.status();
  ExpectViewsMatch(atlas, cameras, *device, kPixels, plain);
}

// The same upload serves every mode and size the pass asks for in turn.
TEST_F(DeviceImpostorViewsTest, EveryModeFromOneUpload) {
  const ImpostorAtlas atlas = BakeSyntheticAtlas({LayoutKind::kOctahedral, 6, 0}, 384);
  auto views = Upload(atlas);
  ASSERT_TRUE(views.ok()) << views.status();
  const std::vector<FrameCamera> cameras = {ViewCameraFor(glm::normalize(glm::vec3(0.31f, 0.42f, 0.77f))),
                                            ViewCameraFor(glm::normalize(glm::vec3(-0.6f, -0.3f, 0.3f))),
                                            ViewCameraFor(glm::normalize(glm::vec3(0.2f, 0.9f, -0.4f)))};
  for (BlendMode blend : {BlendMode::kTriangle3, BlendMode::kBilinear4}) {
    for (Reconstruction mode : {Reconstruction::kDepth, Reconstruction::kPlain}) {
      for (int pixels : {48, 64}) {
        const ReferenceRenderOptions options{.blend = blend, .reconstruction = mode};
        auto device = (*views)->RenderViews(cameras, pixels, options);
        ASSERT_TRUE(device.ok()) << device.status();
        ExpectViewsMatch(atlas, cameras, *device, pixels, options);
      }
    }
  }
}

// A bake without an orm map: views without one, everything else as before.
TEST_F(DeviceImpostorViewsTest, AnAtlasWithoutOrm) {
  ImpostorAtlas atlas = BakeSyntheticAtlas({LayoutKind::kAzimuthElevation, 7, 0}, 448);
  atlas.orm.clear();
  auto views = Upload(atlas);
  ASSERT_TRUE(views.ok()) << views.status();
  const std::vector<FrameCamera> cameras = UpperCameras(3);
  const ReferenceRenderOptions depth{.blend = BlendMode::kTriangle3, .reconstruction = Reconstruction::kDepth};
  auto device = (*views)->RenderViews(cameras, 64, depth);
  ASSERT_TRUE(device.ok()) << device.status();
  for (const ViewImages& v : *device) EXPECT_TRUE(v.orm.empty());
  ExpectViewsMatch(atlas, cameras, *device, 64, depth);
}

TEST_F(DeviceImpostorViewsTest, BadInputsAreRefusedWithAReason) {
  ImpostorAtlas atlas = BakeSyntheticAtlas({LayoutKind::kOctahedral, 4, 0}, 128);
  ImpostorAtlas short_maps = atlas;
  short_maps.normal_depth.resize(short_maps.normal_depth.size() / 2);
  auto refused = Upload(short_maps);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument);
  ImpostorAtlas no_cameras = atlas;
  no_cameras.cameras.pop_back();
  EXPECT_EQ(Upload(no_cameras).status().code(), absl::StatusCode::kInvalidArgument);

  auto views = Upload(atlas);
  ASSERT_TRUE(views.ok()) << views.status();
  const std::vector<FrameCamera> one = UpperCameras(1);
  auto zero = (*views)->RenderViews(one, 0, {});
  ASSERT_FALSE(zero.ok());
  EXPECT_EQ(zero.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(zero.status().message().find("pixels"), std::string_view::npos) << zero.status();
  auto none = (*views)->RenderViews({}, 32, {});
  ASSERT_TRUE(none.ok()) << none.status();
  EXPECT_TRUE(none->empty());
}

}  // namespace
}  // namespace impostor
