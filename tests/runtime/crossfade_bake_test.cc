// The cross-fade at the LOD switch on a real bake: DamagedHelmet baked by the
// worker's Vulkan renderer (lavapipe is enough), drawn from the quality
// pass's pop orbit (worker/bake/quality_pass.h: 36 pairs of views 1 degree
// apart at 20 degrees elevation, 64 px, one sample per pixel; the impostor
// with the CPU reference renderer, depth reconstruction, 3-frame blend).
//
// The claim: fading from the mesh to the impostor over the 16 steps of the
// dither (t = k / 16) never changes the picture from one step to the next
// by more than the impostor itself changes over a 1 degree step. Both are
// measured with the quality pass's pop formula (PopRatio of
// MeanAbsoluteAlbedoChange against the mesh's own change over the same 1
// degree step): the impostor's pop over the orbit, and the fade's, where
// the composite of mesh and impostor (each pixel from the one the SDK's
// CrossFadeDrawsImpostor gives it) is measured at each pair's first view,
// step k against step k + 1. The hard switch (mesh to impostor in one
// frame) is measured the same way, to show what the fade removes.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "common/atlas/frame_camera.h"
#include "common/quality/image_metrics.h"
#include "common/runtime/reference_renderer.h"
#include "impostor/lod.h"
#include "worker/gpu/atlas_renderer.h"
#include "worker/scene/bounding_sphere.h"
#include "worker/scene/gltf_loader.h"

namespace impostor {
namespace {

constexpr int kOrbitPairs = 36;      // QualityPassOptions.orbit_pairs
constexpr int kOrbitPixels = 64;     // .orbit_pixels
constexpr float kElevationDeg = 20;  // .orbit_elevation_deg
constexpr int kFadeSteps = 16;       // the dither's levels: each step moves one

ViewPixels Pixels(const ViewImages& v) { return {v.width, v.height, v.albedo_alpha, v.normal_depth}; }

// Each pixel from the impostor where the fade gives it to the impostor, else
// from the mesh (covered or not: where the chosen one has nothing, nothing
// is drawn).
ViewImages Composite(const ViewImages& mesh, const ViewImages& impostor, float t, uint32_t seed) {
  ViewImages out = mesh;
  for (int y = 0; y < mesh.height; ++y) {
    for (int x = 0; x < mesh.width; ++x) {
      if (!sdk::CrossFadeDrawsImpostor(t, seed, x, y)) continue;
      const size_t p = static_cast<size_t>(y) * mesh.width + x;
      for (int c = 0; c < 4; ++c) {
        out.albedo_alpha[p * 4 + c] = impostor.albedo_alpha[p * 4 + c];
        out.normal_depth[p * 4 + c] = impostor.normal_depth[p * 4 + c];
      }
    }
  }
  return out;
}

class CrossFadeBake : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::filesystem::path path =
        std::filesystem::path(IMPOSTOR_TEST_ASSETS_DIR) / "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb";
    auto scene = LoadGltfScene(path);
    ASSERT_TRUE(scene.ok()) << scene.status();
    scene_ = std::move(*scene);
    auto renderer = AtlasRenderer::Create();
    // A gpu-labelled test fails without a device (lavapipe is enough).
    ASSERT_TRUE(renderer.ok()) << "no Vulkan device: " << renderer.status();
    renderer_ = std::move(*renderer);
  }

  // The mesh from every direction, one tile each of one Render call.
  std::vector<ViewImages> RenderMesh(const BoundingSphere& sphere, const std::vector<glm::vec3>& directions) {
    const int n = static_cast<int>(directions.size());
    const int columns = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(n))));
    std::vector<FrameCamera> cameras;
    for (int i = 0; i < n; ++i) {
      FrameCamera c = ViewCameraFor(directions[i]);
      c.index = i;
      c.tile = {(i % columns) * kOrbitPixels, (i / columns) * kOrbitPixels, kOrbitPixels, kOrbitPixels};
      cameras.push_back(c);
    }
    auto atlas = renderer_->Render(scene_, sphere, cameras, columns * kOrbitPixels, {}, nullptr);
    EXPECT_TRUE(atlas.ok()) << atlas.status();
    std::vector<ViewImages> views;
    if (!atlas.ok()) return views;
    const size_t row = static_cast<size_t>(kOrbitPixels) * 4;
    for (const FrameCamera& c : cameras) {
      ViewImages v;
      v.width = v.height = kOrbitPixels;
      v.albedo_alpha.resize(row * kOrbitPixels);
      v.normal_depth.resize(row * kOrbitPixels);
      for (int y = 0; y < kOrbitPixels; ++y) {
        const size_t src = (static_cast<size_t>(c.tile.y + y) * atlas->width + c.tile.x) * 4;
        std::copy_n(atlas->albedo_alpha.begin() + src, row, v.albedo_alpha.begin() + y * row);
        std::copy_n(atlas->normal_depth.begin() + src, row, v.normal_depth.begin() + y * row);
      }
      views.push_back(std::move(v));
    }
    return views;
  }

  Scene scene_;
  std::unique_ptr<AtlasRenderer> renderer_;
};

TEST_F(CrossFadeBake, FadeStepChangesNoMoreThanTheImpostorsOwnPop) {
  // Hemi-octahedral 12 x 12, as the quality table's rows (at 1024 px).
  const ViewLayout layout{LayoutKind::kHemiOctahedral, 12, 0};
  constexpr int kResolution = 1024;
  ImpostorAtlas atlas;
  atlas.layout = layout.kind;
  atlas.frames = layout.frames;
  atlas.resolution = kResolution;
  atlas.sphere = ComputeBoundingSphere(scene_);
  atlas.cameras = AtlasCameras(layout, kResolution);
  auto baked = renderer_->Render(scene_, atlas.sphere, atlas.cameras, kResolution, {}, nullptr);
  ASSERT_TRUE(baked.ok()) << baked.status();
  atlas.width = baked->width;
  atlas.height = baked->height;
  atlas.albedo_alpha = std::move(baked->albedo_alpha);
  atlas.normal_depth = std::move(baked->normal_depth);
  atlas.orm = std::move(baked->orm);

  // The pop orbit: pair k is azimuth k * 10 degrees and one degree further.
  const float elevation = kElevationDeg * std::numbers::pi_v<float> / 180.0f;
  const float degree = std::numbers::pi_v<float> / 180.0f;
  auto at = [&](float azimuth) {
    return glm::vec3(std::cos(elevation) * std::sin(azimuth), std::sin(elevation),
                     std::cos(elevation) * std::cos(azimuth));
  };
  std::vector<glm::vec3> orbit;
  for (int k = 0; k < kOrbitPairs; ++k) {
    const float azimuth = 2.0f * std::numbers::pi_v<float> * k / kOrbitPairs;
    orbit.push_back(at(azimuth));
    orbit.push_back(at(azimuth + degree));
  }
  const std::vector<ViewImages> mesh = RenderMesh(atlas.sphere, orbit);
  ASSERT_EQ(mesh.size(), orbit.size());
  const ReferenceRenderOptions options{BlendMode::kTriangle3, false, Reconstruction::kDepth};
  std::vector<ViewImages> impostor;
  for (const glm::vec3& d : orbit) impostor.push_back(RenderImpostorView(atlas, ViewCameraFor(d), kOrbitPixels, options));

  std::vector<double> mesh_changes, impostor_changes, hard_switch;
  for (int k = 0; k < kOrbitPairs; ++k) {
    mesh_changes.push_back(MeanAbsoluteAlbedoChange(Pixels(mesh[2 * k]), Pixels(mesh[2 * k + 1])));
    impostor_changes.push_back(MeanAbsoluteAlbedoChange(Pixels(impostor[2 * k]), Pixels(impostor[2 * k + 1])));
    hard_switch.push_back(MeanAbsoluteAlbedoChange(Pixels(mesh[2 * k]), Pixels(impostor[2 * k])));
  }
  const double impostor_pop = PopRatio(impostor_changes, mesh_changes);
  const double hard_pop = PopRatio(hard_switch, mesh_changes);

  double fade_pop = 0;
  int worst_step = -1;
  for (uint32_t seed : {0u, 7u, 12345u}) {
    std::vector<std::vector<double>> step_changes(kFadeSteps);  // [fade step][pair]
    for (int k = 0; k < kOrbitPairs; ++k) {
      ViewImages previous = Composite(mesh[2 * k], impostor[2 * k], 0.0f, seed);
      EXPECT_EQ(previous.albedo_alpha, mesh[2 * k].albedo_alpha) << "t = 0 is the mesh";
      for (int s = 1; s <= kFadeSteps; ++s) {
        ViewImages next = Composite(mesh[2 * k], impostor[2 * k], static_cast<float>(s) / kFadeSteps, seed);
        step_changes[s - 1].push_back(MeanAbsoluteAlbedoChange(Pixels(previous), Pixels(next)));
        previous = std::move(next);
      }
      EXPECT_EQ(previous.albedo_alpha, impostor[2 * k].albedo_alpha) << "t = 1 is the impostor";
    }
    for (int s = 0; s < kFadeSteps; ++s) {
      const double pop = PopRatio(step_changes[s], mesh_changes);
      if (pop > fade_pop) fade_pop = pop, worst_step = s;
    }
  }
  std::printf("[ figures  ] DamagedHelmet hemi-octahedral 12, %d px atlas, pop orbit %d pairs at %d px: impostor pop "
              "%.3f; cross-fade in %d steps, largest step %.3f (step %d -> %d); hard switch %.3f\n",
              kResolution, kOrbitPairs, kOrbitPixels, impostor_pop, kFadeSteps, fade_pop, worst_step,
              worst_step + 1, hard_pop);
  RecordProperty("impostor_pop", std::to_string(impostor_pop));
  RecordProperty("fade_step_pop", std::to_string(fade_pop));
  RecordProperty("hard_switch_pop", std::to_string(hard_pop));
  EXPECT_LE(fade_pop, impostor_pop) << "a step of the fade changes the picture more than the impostor's own pop";
  // What the fade is for: the same formula on the hard switch is larger.
  EXPECT_GT(hard_pop, fade_pop);
}

}  // namespace
}  // namespace impostor
