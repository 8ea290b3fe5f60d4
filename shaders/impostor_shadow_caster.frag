#version 450
// Usage example and compile check for impostorShadowCaster
// (impostor_material.glsl): the impostor in a depth-only shadow pass, its
// card facing the light, alpha-tested, with the pixel depth offset applied.
#extension GL_GOOGLE_include_directive : require
#include "impostor_material.glsl"

layout(push_constant) uniform ImpostorPush {
  mat4 view_projection;  // world -> light clip (orthographic)
  vec4 eye_object;       // xyz: toward the light (unit), object space; w: cross-fade t (kCrossFade)
  ivec4 params;          // layout, frames, tile_size, blend mode
  ivec4 flags;           // x: cross-fade seed (kCrossFade), z: ring_views
  vec4 sphere;           // xyz centre, w radius (object space)
} push;

layout(set = 0, binding = 0) uniform sampler2D albedo_alpha_tex;
layout(set = 0, binding = 1) uniform sampler2D normal_depth_tex;

// As impostor_material_lit.frag: one pipeline per layout and blend mode,
// so the driver compiles only that code; push.params.x and .w are not read.
layout(constant_id = 0) const bool kParallax = false;
layout(constant_id = 1) const int kLayout = IMPOSTOR_LAYOUT_OCTAHEDRAL;
layout(constant_id = 2) const int kBlendMode = IMPOSTOR_BLEND_TRIANGLE3;
// Cross-fade, as impostor_material_lit.frag's: the same decision for the
// shadow map's pixels, so during the fade the mesh's caster (with
// impostorCrossFadeDrawsMesh) and this one split the shadow between them.
layout(constant_id = 3) const bool kCrossFade = false;

layout(location = 0) in vec3 in_ray_origin;
layout(location = 1) in vec3 in_ray_dir;

void main() {
  ImpostorLayout atlas = ImpostorLayout(kLayout, push.params.y, push.flags.z);
  float depth;
  if (!impostorShadowCaster(albedo_alpha_tex, normal_depth_tex, atlas, push.params.z, kBlendMode, kParallax,
                            push.sphere, mat4(1.0), push.view_projection, in_ray_origin,
                            normalize(push.eye_object.xyz), depth)) {
    discard;
  }
  if (kCrossFade && !impostorCrossFadeDrawsImpostor(push.eye_object.w, uint(push.flags.x), ivec2(gl_FragCoord.xy))) {
    discard;
  }
  gl_FragDepth = depth;
}
