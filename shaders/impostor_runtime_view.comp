#version 450
// Renders one orthographic view of an impostor with impostor_runtime.glsl,
// pixel for pixel as RenderImpostorView (common/runtime/reference_renderer.h)
// does: the quality pass's impostor views on a GPU
// (worker/gpu/device_impostor_views.h), and the check of the shader's shading
// against the C++ (tests/runtime/glsl_runtime_test.cc).
#extension GL_GOOGLE_include_directive : require
#include "impostor_runtime.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(push_constant) uniform Push {
  vec4 view_dir;    // xyz: centre -> camera
  vec4 view_up;
  vec4 view_right;
  ivec4 params;     // layout, frames, tile_size, blend mode
  ivec4 flags;      // reconstruction mode (IMPOSTOR_RECONSTRUCT_*), has_orm, pixels, ring_views
  ivec4 placement;  // x: this view's first pixel in `pixels` (several views share one buffer)
} push;

layout(set = 0, binding = 0) uniform sampler2D albedo_alpha_tex;  // SRGB view
layout(set = 0, binding = 1) uniform sampler2D normal_depth_tex;
layout(set = 0, binding = 2) uniform sampler2D orm_tex;
// Per pixel, 3 x vec4: (linear albedo, blended alpha), (unit normal, view
// depth), (orm, 0).
layout(std430, set = 0, binding = 3) writeonly buffer Pixels { vec4 pixels[]; };

void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  int n = push.flags.z;
  if (p.x >= n || p.y >= n) return;
  float inv = 1.0 / float(n);
  vec2 st = vec2((float(p.x) + 0.5) * inv * 2.0 - 1.0, 1.0 - (float(p.y) + 0.5) * inv * 2.0);
  vec3 v = push.view_dir.xyz;
  vec3 origin = st.x * push.view_right.xyz + st.y * push.view_up.xyz + v;
  ImpostorLayout atlas = ImpostorLayout(push.params.x, push.params.y, push.flags.w);
  ImpostorBlend blend = impostorBlendFramesLayout(atlas, v, push.params.w);
  ImpostorSurface s = impostorReconstructLayout(albedo_alpha_tex, normal_depth_tex, orm_tex, push.flags.y != 0,
                                                atlas, push.params.z, blend, origin, -v, push.flags.x);
  uint o = uint(push.placement.x + p.y * n + p.x) * 3u;
  pixels[o + 0u] = vec4(s.albedo, s.alpha);
  pixels[o + 1u] = vec4(s.normal, impostorViewDepth(s.position, v));
  pixels[o + 2u] = vec4(s.orm, 0.0);
}
