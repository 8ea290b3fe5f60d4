// An octahedral atlas of a scene rendered in memory, for quality-pass tests
// that need an ImpostorAtlas without a bake's files (quality_pass_test.cc,
// good_for_pass_test.cc).
#ifndef IMPOSTOR_TESTS_QUALITY_IN_MEMORY_ATLAS_H_
#define IMPOSTOR_TESTS_QUALITY_IN_MEMORY_ATLAS_H_

#include <utility>

#include "absl/status/statusor.h"
#include "common/atlas/frame_camera.h"
#include "common/runtime/reference_renderer.h"
#include "worker/gpu/atlas_renderer.h"
#include "worker/scene/bounding_sphere.h"
#include "worker/scene/scene.h"

namespace impostor::testing {

inline absl::StatusOr<ImpostorAtlas> InMemoryOctahedralAtlas(const Scene& scene, int frames, int resolution,
                                                             AtlasRenderer& renderer) {
  ImpostorAtlas atlas;
  atlas.layout = LayoutKind::kOctahedral;
  atlas.frames = frames;
  atlas.resolution = resolution;
  atlas.sphere = ComputeBoundingSphere(scene);
  atlas.cameras = AtlasCameras(LayoutKind::kOctahedral, frames, resolution);
  RenderTimings timings;
  auto maps = renderer.Render(scene, atlas.sphere, atlas.cameras, resolution, {}, &timings);
  if (!maps.ok()) return maps.status();
  atlas.width = maps->width;
  atlas.height = maps->height;
  atlas.albedo_alpha = std::move(maps->albedo_alpha);
  atlas.normal_depth = std::move(maps->normal_depth);
  return atlas;
}

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_QUALITY_IN_MEMORY_ATLAS_H_
