// Renders the example scene with Vulkan (lavapipe is enough): a ground
// plane, a glTF mesh and its baked impostor, one directional light with a
// shadow map, into an RGBA8 image. The mesh goes through the worker's own
// bake pipeline as a G-buffer and is lit by a deferred pass; the impostor is
// drawn forward as one camera-facing quad with the reference material
// (shaders/impostor_material_lit.frag: lit from the baked normals, pixel
// depth offset) and casts its shadow with shaders/impostor_shadow_caster.frag.
// Both are lit by the same code (shaders/impostor_material_light.glsl).
//
// Not thread-safe; one Render() at a time.
#ifndef IMPOSTOR_EXAMPLES_IMPOSTOR_SCENE_SCENE_RENDERER_H_
#define IMPOSTOR_EXAMPLES_IMPOSTOR_SCENE_SCENE_RENDERER_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "absl/status/statusor.h"
#include "examples/impostor_scene/baked_impostor.h"
#include "worker/scene/scene.h"

namespace impostor::example {

struct SceneSetup {
  int width = 512, height = 512;
  bool draw_mesh = true;
  bool draw_impostor = true;
  bool draw_ground = true;
  bool depth_offset = true;  // false: the impostor keeps its flat card's depth
  // The material's parallax march (a specialization constant: the pipeline
  // is rebuilt when it changes). Without it a perspective camera samples
  // each frame where the ray meets the frame's plane, so points off that
  // plane (the ground crossing, low on the object) shift by tens of pixels.
  bool parallax = true;
  int blend_mode = 0;        // IMPOSTOR_BLEND_TRIANGLE3 / _BILINEAR4
  // World placement: each is translated by its offset (scene space + offset).
  glm::vec3 mesh_offset{0.0f};
  glm::vec3 impostor_offset{0.0f};
  float ground_height = 0.0f;       // world y of the ground plane
  float ground_half_side = 1.0f;    // world units
  glm::vec3 eye{0.0f, 1.0f, 3.0f};  // camera, world
  glm::vec3 target{0.0f};
  float fov_y_degrees = 35.0f;
  glm::vec3 toward_light{0.0f, 1.0f, 0.0f};  // unit after normalisation
};

// The default scene for a mesh whose bounding sphere is (centre, radius):
// the mesh on the left, the impostor on the right, the ground a quarter of
// the way up the sphere so both sink into it, the camera 30 degrees above.
// `side_by_side` false puts both at the same place (for comparisons).
SceneSetup DefaultSetup(glm::vec3 center, float radius, bool side_by_side);

struct SceneImage {
  int width = 0, height = 0;
  // RGBA8, colour sRGB-encoded; alpha 255 where the mesh or the impostor is
  // the visible surface, 0 on the ground and the sky.
  std::vector<uint8_t> rgba;
};

class SceneRenderer {
 public:
  // `device`: substring of a Vulkan device name, or empty (IMPOSTOR_VK_DEVICE, else the first).
  static absl::StatusOr<std::unique_ptr<SceneRenderer>> Create(const std::string& device);
  virtual ~SceneRenderer() = default;

  // INVALID_ARGUMENT for a size outside 16..4096 or an impostor without maps.
  virtual absl::StatusOr<SceneImage> Render(const Scene& mesh, const BakedImpostor& impostor,
                                            const SceneSetup& setup) = 0;
};

}  // namespace impostor::example

#endif  // IMPOSTOR_EXAMPLES_IMPOSTOR_SCENE_SCENE_RENDERER_H_
