#version 450
// Usage example and compile check for impostor_material.glsl: the lit
// impostor with pixel depth offset, under one directional light with a
// shadow map (PCF 3x3). Pairs with impostor_runtime_check.vert's card
// (world = object space here; an engine passes its instance transform).
#extension GL_GOOGLE_include_directive : require
#include "impostor_material.glsl"

layout(push_constant) uniform ImpostorPush {
  mat4 view_projection;  // object (= world) space -> clip
  vec4 eye_object;       // xyz: eye in radius units from the centre
  ivec4 params;          // layout, frames, tile_size, blend mode
  ivec4 flags;           // x: parallax, y: has_orm, z: ring_views
  vec4 sphere;           // xyz centre, w radius (object space)
} push;

layout(set = 0, binding = 0) uniform sampler2D albedo_alpha_tex;  // SRGB view
layout(set = 0, binding = 1) uniform sampler2D normal_depth_tex;
layout(set = 0, binding = 2) uniform sampler2D orm_tex;
layout(set = 0, binding = 3) uniform sampler2DShadow shadow_map;
layout(set = 0, binding = 4) uniform Light {
  mat4 light_view_projection;  // world -> light clip (orthographic)
  vec4 toward_light;           // xyz unit, world space
  vec4 colour;                 // rgb radiance, a = ambient
} light;

layout(location = 0) in vec3 in_ray_origin;
layout(location = 1) in vec3 in_ray_dir;
layout(location = 0) out vec4 out_colour;

float Shadow(vec3 world) {
  vec4 c = light.light_view_projection * vec4(world, 1.0);
  vec3 uvz = vec3(c.xy / c.w * 0.5 + 0.5, c.z / c.w - 0.002);
  vec2 texel = 1.0 / vec2(textureSize(shadow_map, 0));
  float lit = 0.0;
  for (int y = -1; y <= 1; ++y)
    for (int x = -1; x <= 1; ++x) lit += texture(shadow_map, vec3(uvz.xy + vec2(x, y) * texel, uvz.z));
  return lit / 9.0;
}

void main() {
  ImpostorLayout atlas = ImpostorLayout(push.params.x, push.params.y, push.flags.z);
  vec3 view_dir = normalize(push.eye_object.xyz);
  ImpostorPixel px = impostorMaterial(albedo_alpha_tex, normal_depth_tex, orm_tex, push.flags.y != 0, atlas,
                                      push.params.z, push.params.w, push.flags.x != 0, push.sphere, mat4(1.0),
                                      push.view_projection, in_ray_origin, in_ray_dir, view_dir);
  if (px.coverage < 0.5) discard;
  gl_FragDepth = px.frag_depth;
  // Lambert + ambient occlusion: the engine's own BRDF goes here.
  float ndotl = max(dot(px.normal_world, light.toward_light.xyz), 0.0);
  vec3 lit = px.albedo * (light.colour.rgb * ndotl * Shadow(px.position_world) + light.colour.a * px.orm.x);
  out_colour = vec4(lit, 1.0);
}
