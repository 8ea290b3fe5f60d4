// Reference material for impostors (issue 22): what an engine's PBR pass
// needs from a baked atlas, for every layout, on top of
// impostor_runtime.glsl (blend, virtual planes, parallax):
//   - albedo (linear), coverage, occlusion / roughness / metalness;
//   - the scene-space (world) normal from the baked object-space normal map;
//   - the surface point the atlas depth puts under the pixel, in world
//     space, and the pixel depth offset: gl_FragDepth for that point, so the
//     impostor sinks into terrain and intersects other geometry where the
//     mesh would;
//   - a shadow-caster variant: the same surface seen from the light
//     (orthographic, along the light direction), alpha-tested, with the
//     depth offset applied, for a depth-only pass.
//
// Conventions as impostor_runtime.glsl: object space is the glTF scene's,
// the impostor's quad is drawn facing the camera (or the light) and its
// fragments carry the ray in "sphere space" (relative to the bounding
// sphere's centre, in units of its radius). Vulkan clip space: depth 0..1.
//
// Use (colour pass):
//   ImpostorPixel px = impostorMaterial(albedo_tex, normal_depth_tex, orm_tex,
//       has_orm, atlas, tile_size, mode, parallax, sphere, object_to_world,
//       world_to_clip, ray_origin, ray_dir, view_dir);
//   if (px.coverage < 0.5) discard;
//   gl_FragDepth = px.frag_depth;
//   ... the engine's lighting with px.albedo, px.normal_world, px.orm ...
// Use (shadow pass): the same call with the light's world_to_clip, ray_dir
// = -toward_light and view_dir = toward_light, in object space, parallax as
// for the colour pass; discard below 0.5 coverage and write px.frag_depth
// (impostorShadowCaster).
// Cross-fade at the LOD switch (impostor_crossfade.glsl, off unless asked
// for): both passes also discard where
// !impostorCrossFadeDrawsImpostor(t, seed, ivec2(gl_FragCoord.xy)), with the
// instance's t and seed, so its shadow fades with it
// (impostor_material_lit.frag and impostor_shadow_caster.frag: kCrossFade).
#ifndef IMPOSTOR_MATERIAL_GLSL
#define IMPOSTOR_MATERIAL_GLSL

#include "impostor_crossfade.glsl"
#include "impostor_runtime.glsl"

struct ImpostorPixel {
  float coverage;       // blended coverage; covered iff >= 0.5
  vec3 albedo;          // linear
  vec3 orm;             // occlusion, roughness, metalness (0, 1, 0 without an ORM map)
  vec3 normal_world;    // unit, world space
  vec3 position_world;  // the surface point the atlas depth gives
  float frag_depth;     // that point's depth in world_to_clip, 0..1
};

// sphere = (centre.xyz in object space, radius). object_to_world must be a
// similarity (rotation, uniform scale, translation), as for any impostor.
ImpostorPixel impostorMaterial(sampler2D albedo_tex, sampler2D normal_depth_tex, sampler2D orm_tex, bool has_orm,
                               ImpostorLayout atlas, int tile_size, int blend_mode, bool parallax, vec4 sphere,
                               mat4 object_to_world, mat4 world_to_clip, vec3 ray_origin, vec3 ray_dir,
                               vec3 view_dir) {
  ImpostorBlend blend = impostorBlendFramesLayout(atlas, view_dir, blend_mode);
  ImpostorSurface s = impostorShadeLayout(albedo_tex, normal_depth_tex, orm_tex, has_orm, atlas, tile_size, blend,
                                          ray_origin, ray_dir, parallax);
  ImpostorPixel px;
  px.coverage = s.alpha;
  px.albedo = s.albedo;
  px.orm = has_orm ? s.orm : vec3(0.0, 1.0, 0.0);
  // Normals transform with the inverse transpose; for a similarity that is
  // the rotation part, renormalised.
  px.normal_world = normalize(mat3(object_to_world) * (s.normal + vec3(0.0, 0.0, 1e-12)));
  // Without parallax, the surface point is on the frame plane shifted by the
  // sampled depth along the frame's direction: ImpostorSurface.position.
  vec3 object_point = sphere.xyz + sphere.w * s.position;
  vec4 world = object_to_world * vec4(object_point, 1.0);
  px.position_world = world.xyz / world.w;
  vec4 clip = world_to_clip * vec4(px.position_world, 1.0);
  px.frag_depth = clamp(clip.z / clip.w, 0.0, 1.0);
  return px;
}

// Shadow caster: depth only, alpha-tested, depth offset applied. Returns
// false where the fragment must be discarded. With parallax the frames
// agree on the silhouette seen from the light as they do for a camera
// (a box's shadow from between frames: IoU 0.82-0.99 against the mesh's
// with it, 0.52-0.97 without, by layout; web test).
bool impostorShadowCaster(sampler2D albedo_tex, sampler2D normal_depth_tex, ImpostorLayout atlas, int tile_size,
                          int blend_mode, bool parallax, vec4 sphere, mat4 object_to_world, mat4 light_world_to_clip,
                          vec3 ray_origin, vec3 toward_light, out float frag_depth) {
  ImpostorPixel px = impostorMaterial(albedo_tex, normal_depth_tex, albedo_tex, false, atlas, tile_size, blend_mode,
                                      parallax, sphere, object_to_world, light_world_to_clip, ray_origin,
                                      -toward_light, toward_light);
  frag_depth = px.frag_depth;
  return px.coverage >= 0.5;
}

#endif  // IMPOSTOR_MATERIAL_GLSL
