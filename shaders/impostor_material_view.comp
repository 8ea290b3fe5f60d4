#version 450
// Renders one orthographic view of an impostor through impostor_material.glsl
// (impostorMaterial, or impostorShadowCaster from the light), pixel for
// pixel as impostor_runtime_view.comp lays its pixels out, so tests can
// check the pixel depth offset and the shadow caster against the ray-cast
// object (tests/runtime/glsl_material_test.cc), and that both passes keep
// the same cross-fade share of pixels (tests/runtime/glsl_crossfade_test.cc).
#extension GL_GOOGLE_include_directive : require
#include "impostor_material.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(push_constant) uniform Push {
  mat4 world_to_clip;  // the view's orthographic camera (world = object space)
  vec4 view_dir;       // xyz: centre -> camera (toward the light for the caster)
  vec4 sphere;         // xyz centre, w radius
  ivec4 params;        // layout, frames, tile_size, blend mode
  ivec4 flags;         // x: 1 = shadow caster, y: pixels, z: ring_views, w: parallax
} push;

layout(set = 0, binding = 0) uniform sampler2D albedo_alpha_tex;  // SRGB view
layout(set = 0, binding = 1) uniform sampler2D normal_depth_tex;
layout(set = 0, binding = 2) uniform sampler2D orm_tex;
// Per pixel, 2 x vec4: (linear albedo, coverage), (world normal, frag depth);
// the caster writes (0, 0, 0, covered ? 1 : 0), (0, 0, 0, frag depth).
layout(std430, set = 0, binding = 3) writeonly buffer Pixels { vec4 pixels[]; };
// Cross-fade (impostor_crossfade.glsl): x = 1 on, y = t (float bits), z =
// seed; the pixel (x, y) stands for gl_FragCoord. A pixel the fade gives to
// the mesh is written as uncovered (coverage 0 / caster 0), the rest as
// without the fade.
layout(std430, set = 0, binding = 4) readonly buffer CrossFade { uvec4 cross_fade; };

void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  int n = push.flags.y;
  if (p.x >= n || p.y >= n) return;
  float inv = 1.0 / float(n);
  vec2 st = vec2((float(p.x) + 0.5) * inv * 2.0 - 1.0, 1.0 - (float(p.y) + 0.5) * inv * 2.0);
  vec3 v = normalize(push.view_dir.xyz);
  ImpostorFrameCamera cam = impostorCameraForDirection(v);
  vec3 origin = st.x * cam.right + st.y * cam.up + v;
  ImpostorLayout atlas = ImpostorLayout(push.params.x, push.params.y, push.flags.z);
  uint o = uint(p.y * n + p.x) * 2u;
  bool faded_out = cross_fade.x != 0u && !impostorCrossFadeDrawsImpostor(uintBitsToFloat(cross_fade.y), cross_fade.z, p);
  if (push.flags.x != 0) {
    float depth;
    bool covered = impostorShadowCaster(albedo_alpha_tex, normal_depth_tex, atlas, push.params.z, push.params.w,
                                        push.flags.w != 0, push.sphere, mat4(1.0), push.world_to_clip, origin, v,
                                        depth);
    pixels[o + 0u] = vec4(0.0, 0.0, 0.0, covered && !faded_out ? 1.0 : 0.0);
    pixels[o + 1u] = vec4(0.0, 0.0, 0.0, depth);
    return;
  }
  ImpostorPixel px = impostorMaterial(albedo_alpha_tex, normal_depth_tex, orm_tex, true, atlas, push.params.z,
                                      push.params.w, push.flags.w != 0, push.sphere, mat4(1.0), push.world_to_clip, origin, -v,
                                      v);
  pixels[o + 0u] = vec4(px.albedo, faded_out ? 0.0 : px.coverage);
  pixels[o + 1u] = vec4(px.normal_world, px.frag_depth);
}
