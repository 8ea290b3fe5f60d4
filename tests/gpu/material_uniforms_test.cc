// The bake shader's per-slot UV mapping (worker/gpu/bake_pipeline.h,
// MakeMaterialUniforms): a slot with a texture keeps its set and
// KHR_texture_transform; a slot without one maps every UV to 0, since it
// samples a 1x1 default whatever the UV, and huge raw UVs (unnormalised
// quantized texcoords) made lavapipe's filtering of it take minutes.
#include "worker/gpu/bake_pipeline.h"

#include <gtest/gtest.h>

namespace impostor::gpu {
namespace {

TEST(MaterialUniforms, OnlySlotsWithATextureKeepTheirTransform) {
  SceneMaterial m;
  m.base_color_texture = 0;
  m.uv[kSlotBaseColor].tex_coord = 1;
  m.uv[kSlotBaseColor].transform = glm::mat3(0.5f, 0.0f, 0.0f, 0.0f, 0.25f, 0.0f, 0.1f, 0.2f, 1.0f);
  m.uv[kSlotOcclusion].transform = glm::mat3(2.0f);  // no occlusion texture
  const MaterialUniforms u = MakeMaterialUniforms(m);
  EXPECT_EQ(u.row0[kSlotBaseColor], glm::vec4(0.5f, 0.0f, 0.1f, 1.0f)) << "scale, offset and TEXCOORD_1";
  EXPECT_EQ(u.row1[kSlotBaseColor], glm::vec4(0.0f, 0.25f, 0.2f, 0.0f));
  for (int slot : {kSlotMetallicRoughness, kSlotNormal, kSlotOcclusion, kSlotEmissive}) {
    EXPECT_EQ(glm::vec3(u.row0[slot]), glm::vec3(0.0f)) << slot;
    EXPECT_EQ(glm::vec3(u.row1[slot]), glm::vec3(0.0f)) << slot;
  }
}

}  // namespace
}  // namespace impostor::gpu
