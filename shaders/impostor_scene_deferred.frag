#version 450
// examples/impostor_scene: lights the mesh's G-buffer (what the worker's
// bake shader writes: albedo, scene-space normal + window depth, ORM) with
// impostor_material_light.glsl, so the mesh is lit exactly as the impostor.
#extension GL_GOOGLE_include_directive : require
#include "impostor_material_light.glsl"

layout(push_constant) uniform Push {
  mat4 clip_to_world;  // inverse of the camera's world -> clip
} push;

layout(set = 0, binding = 0) uniform sampler2D gbuffer_albedo;        // SRGB view
layout(set = 0, binding = 1) uniform sampler2D gbuffer_normal_depth;  // normal * 0.5 + 0.5, window depth
layout(set = 0, binding = 2) uniform sampler2D gbuffer_orm;

layout(location = 0) in vec2 in_uv;
layout(location = 0) out vec4 out_colour;

void main() {
  vec4 albedo = texture(gbuffer_albedo, in_uv);
  if (albedo.a < 0.5) discard;  // no mesh here
  vec4 nd = texture(gbuffer_normal_depth, in_uv);
  vec4 world = push.clip_to_world * vec4(in_uv * 2.0 - 1.0, nd.a, 1.0);
  vec3 normal = normalize(nd.xyz * 2.0 - 1.0);
  float occlusion = texture(gbuffer_orm, in_uv).r;
  out_colour = vec4(impostorLambert(albedo.rgb, normal, occlusion, world.xyz / world.w), 1.0);
}
