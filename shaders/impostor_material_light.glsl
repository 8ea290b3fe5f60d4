// One directional light with an orthographic shadow map, as the reference
// material's lit example (impostor_material_lit.frag) and the example scene
// (examples/impostor_scene) share it, so the impostor, the mesh and the
// ground are lit by the very same code: Lambert + ambient x occlusion, the
// shadow filtered 3x3 (PCF). An engine replaces this with its own lights.
//
// The including stage declares nothing else at set 0 bindings 3 and 4.
#ifndef IMPOSTOR_MATERIAL_LIGHT_GLSL
#define IMPOSTOR_MATERIAL_LIGHT_GLSL

layout(set = 0, binding = 3) uniform sampler2DShadow shadow_map;
layout(set = 0, binding = 4) uniform Light {
  mat4 light_view_projection;  // world -> light clip (orthographic)
  vec4 toward_light;           // xyz unit, world space
  vec4 colour;                 // rgb radiance, a = ambient
} light;

// 1 = fully lit, 0 = in shadow. The bias is in light clip depth (0..1).
float impostorShadow(vec3 world) {
  vec4 c = light.light_view_projection * vec4(world, 1.0);
  vec3 uvz = vec3(c.xy / c.w * 0.5 + 0.5, c.z / c.w - 0.002);
  vec2 texel = 1.0 / vec2(textureSize(shadow_map, 0));
  float lit = 0.0;
  for (int y = -1; y <= 1; ++y)
    for (int x = -1; x <= 1; ++x) lit += texture(shadow_map, vec3(uvz.xy + vec2(x, y) * texel, uvz.z));
  return lit / 9.0;
}

// Linear radiance leaving a Lambert surface (the engine's BRDF goes here).
vec3 impostorLambert(vec3 albedo, vec3 normal_world, float occlusion, vec3 world) {
  float ndotl = max(dot(normal_world, light.toward_light.xyz), 0.0);
  return albedo * (light.colour.rgb * ndotl * impostorShadow(world) + light.colour.a * occlusion);
}

#endif  // IMPOSTOR_MATERIAL_LIGHT_GLSL
