// A baked atlas result directory (what `impostor bake --out DIR` writes:
// manifest.json + albedo_alpha.png, normal_depth.png, orm.png) read into
// memory for the example scene: the layout numbers the GLSL material takes
// and the three maps as the GPU will hold them.
#ifndef IMPOSTOR_EXAMPLES_IMPOSTOR_SCENE_BAKED_IMPOSTOR_H_
#define IMPOSTOR_EXAMPLES_IMPOSTOR_SCENE_BAKED_IMPOSTOR_H_

#include <cstdint>
#include <filesystem>
#include <vector>

#include <glm/vec3.hpp>

#include "absl/status/statusor.h"

namespace impostor::example {

struct BakedImpostor {
  int layout = 0;      // IMPOSTOR_LAYOUT_* of shaders/impostor_runtime.glsl
  int frames = 0;      // the manifest's `frames`
  int ring_views = 0;  // ring-top: views - 1; billboard: 8; others 0
  int tile_size = 0;   // pixels per frame side
  glm::vec3 sphere_center{0.0f};
  float sphere_radius = 0.0f;
  int width = 0, height = 0;            // every map has this size
  std::vector<uint8_t> albedo_alpha;    // RGBA8, sRGB colour + coverage
  std::vector<uint16_t> normal_depth;   // RGBA16
  std::vector<uint8_t> orm;             // RGBA8
};

// Errors name the directory and what is wrong: NOT_FOUND for a missing
// directory, manifest or map; INVALID_ARGUMENT for a manifest that is not an
// atlas in PNG maps (a surfel, cards or LOD product, KTX2 maps, a view count
// the layout cannot have, maps of another size than `resolution`).
absl::StatusOr<BakedImpostor> LoadBakedImpostor(const std::filesystem::path& dir);

}  // namespace impostor::example

#endif  // IMPOSTOR_EXAMPLES_IMPOSTOR_SCENE_BAKED_IMPOSTOR_H_
