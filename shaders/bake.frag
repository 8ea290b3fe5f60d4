#version 450
// Impostor bake, fragment stage: writes the three atlas maps (four with
// emissive).
//   0 albedo_alpha (R8G8B8A8_SRGB): unlit base colour, A = coverage
//   1 normal_depth (R16G16B16A16_UNORM): scene-space normal * 0.5 + 0.5,
//     A = normalised depth
//   2 orm (R8G8B8A8_UNORM): occlusion, roughness, metalness, A = coverage
//   3 emissive (R8G8B8A8_SRGB, optional): emissive colour, A = coverage
// Coverage is written as 1 for every fragment that survives, so the clear
// value 0 marks empty texels in the atlas.
//
// Alpha (base colour alpha = texture x factor x COLOR_0 alpha):
//   OPAQUE  alpha is ignored: every fragment is covered.
//   MASK    fragments with alpha < alphaCutoff are discarded.
//   BLEND   baked as a cutout at alpha >= 0.5 (the MASK default cutoff).
//           Why: an impostor texel holds one surface (one normal, one
//           depth) and engines draw impostors alpha-tested, so a blended
//           surface has to become "there" or "not there"; a fixed threshold
//           keeps it deterministic and noise-free, where an ordered dither
//           (alpha-to-coverage) would put noise into the normal and depth
//           maps and mix surfaces of different depths when supersampled
//           frames are downsampled. Half-transparent glass therefore stays,
//           faint veils (alpha < 0.5) vanish.

layout(location = 0) in vec3 in_normal;
layout(location = 1) in vec4 in_tangent;
layout(location = 2) in vec4 in_uv01;  // xy TEXCOORD_0, zw TEXCOORD_1
layout(location = 3) in vec4 in_color;  // COLOR_0, linear

// Must match MaterialPushConstants in worker/gpu/bake_pipeline.h.
layout(push_constant) uniform MaterialPush {
  layout(offset = 64) vec4 base_color_factor;  // linear
  float metallic_factor;
  float roughness_factor;
  float normal_scale;
  float occlusion_strength;
  float alpha_cutoff;
  uint alpha_mode;       // 0 OPAQUE, 1 MASK, 2 BLEND
  uint has_normal_map;   // 0: keep the interpolated normal (see below)
  uint pad;
} material;

// The base colour view is sRGB, so sampling returns linear colour; the other
// three are UNORM views of data. Missing textures are bound to 1x1 defaults
// (white; flat normal), so every material has all four.
layout(set = 0, binding = 0) uniform sampler2D base_color_tex;
layout(set = 0, binding = 1) uniform sampler2D metallic_roughness_tex;
layout(set = 0, binding = 2) uniform sampler2D normal_tex;
layout(set = 0, binding = 3) uniform sampler2D occlusion_tex;
layout(set = 0, binding = 4) uniform sampler2D emissive_tex;  // sRGB view

// Per-material UV mapping of each texture slot (0 base colour, 1 metal-
// rough, 2 normal, 3 occlusion, 4 emissive): which UV set it reads and its
// KHR_texture_transform. Must match MaterialUniforms in
// worker/gpu/bake_pipeline.h (std140).
layout(set = 0, binding = 5) uniform MaterialUniform {
  // uv' = (dot(row0.xyz, vec3(uv, 1)), dot(row1.xyz, vec3(uv, 1)));
  // row0.w = UV set (0 or 1).
  vec4 row0[5];
  vec4 row1[5];
  vec4 emissive;  // rgb = emissiveFactor x emissive_strength (linear)
} uv_map;

vec2 SlotUv(int slot) {
  vec2 uv = uv_map.row0[slot].w > 0.5 ? in_uv01.zw : in_uv01.xy;
  vec3 h = vec3(uv, 1.0);
  return vec2(dot(uv_map.row0[slot].xyz, h), dot(uv_map.row1[slot].xyz, h));
}

layout(location = 0) out vec4 out_albedo_alpha;
layout(location = 1) out vec4 out_normal_depth;
layout(location = 2) out vec4 out_orm;
// R8G8B8A8_SRGB, only bound when the emissive map is requested: emissive
// texture x factor x strength (linear in, clamped to 1 by the format),
// A = coverage.
layout(location = 3) out vec4 out_emissive;

const uint kAlphaOpaque = 0u;
const uint kAlphaMask = 1u;
const uint kAlphaBlend = 2u;

void main() {
  vec4 base = texture(base_color_tex, SlotUv(0)) * material.base_color_factor * in_color;

  if (material.alpha_mode != kAlphaOpaque) {
    // BLEND: cutout at 0.5, see the alpha rule at the top of this file.
    float cutoff = material.alpha_mode == kAlphaMask ? material.alpha_cutoff : 0.5;
    if (base.a < cutoff) discard;
  }

  // Back faces reach this point only for double-sided materials (single-
  // sided ones are culled), and must show the side facing the camera.
  float side = gl_FrontFacing ? 1.0 : -1.0;
  vec3 n = normalize(in_normal) * side;

  // Without a normal map the flat default (128,128,255) would tilt normals
  // by 1/255 and need a valid tangent, which meshes without normal maps
  // often lack; so the map is only applied when the material has one.
  if (material.has_normal_map != 0u) {
    vec3 t = in_tangent.xyz * side;
    t = t - n * dot(n, t);  // Gram-Schmidt: interpolation breaks orthogonality
    float t_len = length(t);
    if (t_len > 1e-6) {
      t /= t_len;
      // On a back face the whole frame is mirrored (the back surface's normal
      // is minus the front's perturbed normal), so b flips with t and n;
      // cross(-n, -t) alone would not flip it.
      vec3 b = cross(n, t) * (in_tangent.w < 0.0 ? -1.0 : 1.0) * side;
      vec3 tn = texture(normal_tex, SlotUv(2)).xyz * 2.0 - 1.0;
      tn.xy *= material.normal_scale;
      vec3 mapped = mat3(t, b, n) * tn;
      float len = length(mapped);
      if (len > 1e-6) n = mapped / len;
    }
  }

  float occlusion_sample = texture(occlusion_tex, SlotUv(3)).r;
  vec4 metal_rough = texture(metallic_roughness_tex, SlotUv(1));

  out_albedo_alpha = vec4(base.rgb, 1.0);
  out_emissive = vec4(texture(emissive_tex, SlotUv(4)).rgb * uv_map.emissive.rgb, 1.0);
  // The frame matrix maps depth to z in [0, 1] with w = 1, so the window z
  // (viewport depth range 0..1) is the normalised depth of the manifest.
  out_normal_depth = vec4(n * 0.5 + 0.5, gl_FragCoord.z);
  out_orm = vec4(1.0 + material.occlusion_strength * (occlusion_sample - 1.0),
                 material.roughness_factor * metal_rough.g,
                 material.metallic_factor * metal_rough.b,
                 1.0);
}
