#version 450
// Compile check and usage example for impostor_runtime.glsl: shades one
// impostor fragment the way the CPU reference renderer does.
#extension GL_GOOGLE_include_directive : require
#include "impostor_runtime.glsl"

layout(push_constant) uniform ImpostorPush {
  mat4 view_projection;
  vec4 eye_object;
  ivec4 params;  // layout, frames, tile_size, blend mode
  ivec4 flags;   // x: parallax, y: has_orm
  vec4 sphere;
} push;

layout(set = 0, binding = 0) uniform sampler2D albedo_alpha_tex;  // SRGB view
layout(set = 0, binding = 1) uniform sampler2D normal_depth_tex;
layout(set = 0, binding = 2) uniform sampler2D orm_tex;

layout(location = 0) in vec3 in_ray_origin;
layout(location = 1) in vec3 in_ray_dir;

layout(location = 0) out vec4 out_albedo_alpha;
layout(location = 1) out vec4 out_normal_depth;
layout(location = 2) out vec4 out_orm;

void main() {
  vec3 view_dir = normalize(push.eye_object.xyz);
  ImpostorBlend blend = impostorBlendFrames(push.params.x, push.params.y, view_dir, push.params.w);
  ImpostorSurface s = impostorShade(albedo_alpha_tex, normal_depth_tex, orm_tex, push.flags.y != 0, push.params.x,
                                    push.params.y, push.params.z, blend, in_ray_origin, in_ray_dir,
                                    push.flags.x != 0);
  if (s.alpha < 0.5) discard;
  out_albedo_alpha = vec4(s.albedo, 1.0);
  out_normal_depth = vec4(s.normal * 0.5 + 0.5, impostorViewDepth(s.position, view_dir));
  out_orm = vec4(s.orm, 1.0);
}
