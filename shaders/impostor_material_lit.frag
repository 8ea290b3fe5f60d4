#version 450
// Usage example for impostor_material.glsl: the lit impostor with pixel
// depth offset, under one directional light with a shadow map
// (impostor_material_light.glsl). Pairs with impostor_runtime_check.vert's
// card; examples/impostor_scene draws it next to the mesh.
#extension GL_GOOGLE_include_directive : require
#include "impostor_material.glsl"
#include "impostor_material_light.glsl"

layout(push_constant) uniform ImpostorPush {
  mat4 view_projection;  // object space -> clip (the card's vertex stage)
  vec4 eye_object;       // xyz: eye in radius units from the centre; w: cross-fade t (kCrossFade)
  ivec4 params;          // layout, frames, tile_size, blend mode
  ivec4 flags;           // x: cross-fade seed (kCrossFade), y: has_orm, z: ring_views, w: 1 = no depth offset (a flat card)
  vec4 sphere;           // xyz centre, w radius (object space)
} push;

layout(set = 0, binding = 0) uniform sampler2D albedo_alpha_tex;  // SRGB view
layout(set = 0, binding = 1) uniform sampler2D normal_depth_tex;
layout(set = 0, binding = 2) uniform sampler2D orm_tex;
// Bindings 3 (shadow map) and 4 (light): impostor_material_light.glsl.
layout(set = 0, binding = 5) uniform Instance {
  mat4 object_to_world;  // a similarity: rotation, uniform scale, translation
  mat4 world_to_clip;    // the camera
} instance;

// Specialization constants: the driver drops the code of the other layouts,
// blend modes (and the parallax march when off) at pipeline creation (a CPU
// driver's shader compile goes from many minutes to seconds). An engine builds one
// pipeline per layout in use; push.params.x and .w are then not read.
layout(constant_id = 0) const bool kParallax = false;
layout(constant_id = 1) const int kLayout = IMPOSTOR_LAYOUT_OCTAHEDRAL;
layout(constant_id = 2) const int kBlendMode = IMPOSTOR_BLEND_TRIANGLE3;
// Cross-fade at the LOD switch (impostor_crossfade.glsl): on, the instance
// keeps only its share of pixels for t = eye_object.w and seed = flags.x;
// its mesh draws the rest (impostorCrossFadeDrawsMesh). Off (the default),
// neither is read and the output is unchanged.
layout(constant_id = 3) const bool kCrossFade = false;

layout(location = 0) in vec3 in_ray_origin;
layout(location = 1) in vec3 in_ray_dir;
layout(location = 0) out vec4 out_colour;

void main() {
  ImpostorLayout atlas = ImpostorLayout(kLayout, push.params.y, push.flags.z);
  vec3 view_dir = normalize(push.eye_object.xyz);
  ImpostorPixel px = impostorMaterial(albedo_alpha_tex, normal_depth_tex, orm_tex, push.flags.y != 0, atlas,
                                      push.params.z, kBlendMode, kParallax, push.sphere,
                                      instance.object_to_world, instance.world_to_clip, in_ray_origin, in_ray_dir,
                                      view_dir);
  if (px.coverage < 0.5) discard;
  if (kCrossFade && !impostorCrossFadeDrawsImpostor(push.eye_object.w, uint(push.flags.x), ivec2(gl_FragCoord.xy))) {
    discard;
  }
  // The pixel depth offset. flags.w keeps the card's own depth: only for
  // showing (and testing) what the offset fixes.
  gl_FragDepth = push.flags.w != 0 ? gl_FragCoord.z : px.frag_depth;
  // Alpha 1 marks "an object is the visible surface" for the example's tests.
  out_colour = vec4(impostorLambert(px.albedo, px.normal_world, px.orm.x, px.position_world), 1.0);
}
