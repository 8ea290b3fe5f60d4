// The device-side supersample resolve (worker/gpu/supersample_resolve.h,
// shaders/supersample_resolve.comp) against the CPU reference
// (worker/output/supersample.h, DownsampleMaps) on real glTF assets: the same
// renderer bakes the same supersampled atlas twice, once read back whole and
// filtered on the CPU, once filtered on the device, and the pixels are
// compared map by map.
//
// Stated tolerance: coverage, depth and ORM are integer means and must be
// identical; albedo, emissive (sRGB decode/encode in float instead of the
// CPU's table and double sums) and normals (renormalised in float instead of
// double) may differ by one level of their 8- or 16-bit encoding, on at most
// 1% of the covered texels.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "common/atlas/frame_camera.h"
#include "worker/gpu/atlas_renderer.h"
#include "worker/output/supersample.h"
#include "worker/scene/bounding_sphere.h"
#include "worker/scene/gltf_loader.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

fs::path Asset(const std::string& relative) {
  const char* env = std::getenv("IMPOSTOR_ASSETS_DIR");
  return fs::path(env != nullptr ? env : IMPOSTOR_ASSETS_DIR) / relative;
}

// Per map: how many channel values differ at all, the largest difference,
// and how many texels differ anywhere.
struct MapDiff {
  size_t values_differing = 0;
  int max_difference = 0;
  size_t texels_differing = 0;
};

template <typename T>
MapDiff Compare(const std::vector<T>& a, const std::vector<T>& b, int channels_checked = 4) {
  MapDiff d;
  for (size_t t = 0; t + 3 < a.size(); t += 4) {
    bool any = false;
    for (int c = 0; c < channels_checked; ++c) {
      const int diff = std::abs(static_cast<int>(a[t + c]) - static_cast<int>(b[t + c]));
      if (diff == 0) continue;
      any = true;
      ++d.values_differing;
      d.max_difference = std::max(d.max_difference, diff);
    }
    d.texels_differing += any ? 1 : 0;
  }
  return d;
}

size_t CoveredTexels(const std::vector<uint8_t>& albedo) {
  size_t n = 0;
  for (size_t i = 3; i < albedo.size(); i += 4) n += albedo[i] > 0 ? 1 : 0;
  return n;
}

// Texels whose coverage is neither 0 nor 255: silhouette blocks, where the
// covered-only means matter.
size_t PartialTexels(const std::vector<uint8_t>& albedo) {
  size_t n = 0;
  for (size_t i = 3; i < albedo.size(); i += 4) n += albedo[i] > 0 && albedo[i] < 255 ? 1 : 0;
  return n;
}

class SupersampleResolveTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto r = AtlasRenderer::Create();
    ASSERT_TRUE(r.ok()) << r.status();
    renderer_ = std::move(*r).release();
  }
  static void TearDownTestSuite() {
    delete renderer_;
    renderer_ = nullptr;
  }

  // Bakes `asset` as an octahedral `frames` x `frames` atlas of `resolution`
  // px supersampled by `factor`, with the CPU and the device resolve.
  void BakeBothWays(const std::string& asset, int frames, int resolution, int factor, bool emissive,
                    AtlasImages* host, AtlasImages* device) {
    const fs::path path = Asset(asset);
    if (!fs::exists(path)) GTEST_SKIP() << "asset missing: " << path;
    auto scene = LoadGltfScene(path);
    ASSERT_TRUE(scene.ok()) << scene.status();
    const BoundingSphere sphere = ComputeBoundingSphere(*scene);
    const std::vector<FrameCamera> cameras =
        SupersampledCameras(AtlasCameras(LayoutKind::kOctahedral, frames, resolution), factor);
    renderer_->set_emissive(emissive);
    renderer_->set_supersampling(factor);
    renderer_->set_resolve_on_device(false);
    auto full = renderer_->Render(*scene, sphere, cameras, resolution * factor, {}, nullptr);
    renderer_->set_resolve_on_device(true);
    auto resolved = renderer_->Render(*scene, sphere, cameras, resolution * factor, {}, nullptr);
    renderer_->set_resolve_on_device(false);
    renderer_->set_supersampling(1);
    renderer_->set_emissive(false);
    ASSERT_TRUE(full.ok()) << full.status();
    ASSERT_TRUE(resolved.ok()) << resolved.status();
    ASSERT_EQ(full->width, resolution * factor);
    AtlasMaps maps{full->width, full->height, std::move(full->albedo_alpha), std::move(full->normal_depth),
                   std::move(full->orm), std::move(full->emissive)};
    ASSERT_TRUE(DownsampleMaps(factor, &maps).ok());
    host->width = maps.width;
    host->height = maps.height;
    host->albedo_alpha = std::move(maps.albedo_alpha);
    host->normal_depth = std::move(maps.normal_depth);
    host->orm = std::move(maps.orm);
    host->emissive = std::move(maps.emissive);
    *device = std::move(*resolved);
  }

  static void ExpectWithinTolerance(const AtlasImages& host, const AtlasImages& device, const std::string& what) {
    ASSERT_EQ(device.width, host.width) << what;
    ASSERT_EQ(device.height, host.height) << what;
    ASSERT_EQ(device.albedo_alpha.size(), host.albedo_alpha.size()) << what;
    ASSERT_EQ(device.normal_depth.size(), host.normal_depth.size()) << what;
    ASSERT_EQ(device.orm.size(), host.orm.size()) << what;
    ASSERT_EQ(device.emissive.size(), host.emissive.size()) << what;
    const size_t covered = CoveredTexels(host.albedo_alpha);
    ASSERT_GT(covered, 0u) << what;
    const size_t budget = covered / 100;

    // Coverage (every map's alpha), ORM and depth: identical.
    for (size_t i = 3; i < host.albedo_alpha.size(); i += 4) {
      ASSERT_EQ(device.albedo_alpha[i], host.albedo_alpha[i]) << what << " coverage at texel " << i / 4;
      ASSERT_EQ(device.orm[i], host.orm[i]) << what << " orm alpha at texel " << i / 4;
      ASSERT_EQ(device.normal_depth[i], host.normal_depth[i]) << what << " depth at texel " << i / 4;
    }
    const MapDiff orm = Compare(device.orm, host.orm);
    EXPECT_EQ(orm.values_differing, 0u) << what << " orm, largest difference " << orm.max_difference;

    const MapDiff albedo = Compare(device.albedo_alpha, host.albedo_alpha, 3);
    EXPECT_LE(albedo.max_difference, 1) << what << " albedo";
    EXPECT_LE(albedo.texels_differing, budget) << what << " albedo texels off by one, of " << covered;
    const MapDiff normal = Compare(device.normal_depth, host.normal_depth, 3);
    EXPECT_LE(normal.max_difference, 1) << what << " normal";
    EXPECT_LE(normal.texels_differing, budget) << what << " normal texels off by one, of " << covered;
    if (!host.emissive.empty()) {
      const MapDiff e = Compare(device.emissive, host.emissive);
      EXPECT_LE(e.max_difference, 1) << what << " emissive";
      EXPECT_LE(e.texels_differing, budget) << what << " emissive texels off by one, of " << covered;
    }
    std::printf("%s: %zu covered texels (%zu partial); texels off by one: albedo %zu, normal %zu\n", what.c_str(),
                covered, PartialTexels(host.albedo_alpha), albedo.texels_differing, normal.texels_differing);
  }

  static inline AtlasRenderer* renderer_ = nullptr;
};

TEST_F(SupersampleResolveTest, DamagedHelmetTwoByTwoWithEmissiveMatchesTheCpuResolve) {
  AtlasImages host, device;
  BakeBothWays("props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb", 4, 256, 2, /*emissive=*/true, &host,
               &device);
  if (HasFatalFailure() || IsSkipped()) return;
  ASSERT_FALSE(device.emissive.empty());
  EXPECT_GT(PartialTexels(host.albedo_alpha), 100u);  // silhouettes were exercised
  ExpectWithinTolerance(host, device, "DamagedHelmet 2x2");
}

TEST_F(SupersampleResolveTest, AlphaMaskedTreeThreeAndFourMatchTheCpuResolve) {
  // Leaves cut by alphaCutoff give many partly covered blocks; factors 3
  // and 4 check the block indexing and the coverage levels in between, and
  // two resolves in a row check the descriptor set is re-pointed.
  for (int factor : {4, 3}) {
    AtlasImages host, device;
    BakeBothWays("vegetation/Quaternius_CommonTree_1/CommonTree_1.glb", 3, 192, factor, /*emissive=*/false,
                 &host, &device);
    if (HasFatalFailure() || IsSkipped()) return;
    EXPECT_TRUE(device.emissive.empty());
    EXPECT_GT(PartialTexels(host.albedo_alpha), 100u);
    ExpectWithinTolerance(host, device, "CommonTree_1 " + std::to_string(factor) + "x" + std::to_string(factor));
  }
}

TEST_F(SupersampleResolveTest, AnAtlasNotDivisibleByTheFactorIsRefusedNamingBoth) {
  auto scene = LoadGltfScene(Asset("props_pbr/Box/glTF-Binary/Box.glb"));
  if (!scene.ok()) GTEST_SKIP() << scene.status();
  const BoundingSphere sphere = ComputeBoundingSphere(*scene);
  std::vector<FrameCamera> cameras = AtlasCameras(LayoutKind::kOctahedral, 2, 100);
  renderer_->set_supersampling(3);
  renderer_->set_resolve_on_device(true);
  auto out = renderer_->Render(*scene, sphere, cameras, 100, {}, nullptr);
  renderer_->set_resolve_on_device(false);
  renderer_->set_supersampling(1);
  ASSERT_FALSE(out.ok());
  EXPECT_EQ(out.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(out.status().message().find("100x100"), std::string::npos) << out.status();
  EXPECT_NE(out.status().message().find("factor of 3"), std::string::npos) << out.status();
  // The renderer is still usable afterwards.
  auto again = renderer_->Render(*scene, sphere, cameras, 100, {}, nullptr);
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_GT(CoveredTexels(again->albedo_alpha), 0u);
}

TEST_F(SupersampleResolveTest, ResolveIsIgnoredWithoutSupersampling) {
  auto scene = LoadGltfScene(Asset("props_pbr/Box/glTF-Binary/Box.glb"));
  if (!scene.ok()) GTEST_SKIP() << scene.status();
  const BoundingSphere sphere = ComputeBoundingSphere(*scene);
  std::vector<FrameCamera> cameras = AtlasCameras(LayoutKind::kOctahedral, 2, 64);
  auto plain = renderer_->Render(*scene, sphere, cameras, 64, {}, nullptr);
  renderer_->set_resolve_on_device(true);
  auto flagged = renderer_->Render(*scene, sphere, cameras, 64, {}, nullptr);
  renderer_->set_resolve_on_device(false);
  ASSERT_TRUE(plain.ok()) << plain.status();
  ASSERT_TRUE(flagged.ok()) << flagged.status();
  EXPECT_EQ(flagged->width, 64);
  EXPECT_EQ(flagged->albedo_alpha, plain->albedo_alpha);
  EXPECT_EQ(flagged->normal_depth, plain->normal_depth);
}

}  // namespace
}  // namespace impostor
