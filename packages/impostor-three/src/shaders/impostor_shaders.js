// The reference impostor material's stages for three.js (GLSL ES 3.00,
// ShaderMaterial), on top of shaders/impostor_runtime.glsl (embedded in
// impostor_runtime.glsl.js). What each part ports:
//   - the card and the sphere-space ray: shaders/impostor_runtime_check.vert
//     (a camera-facing square of the sphere's diameter, one radius toward
//     the camera); for an orthographic camera (a directional light's shadow
//     camera too) the rays run parallel along the view, as
//     shaders/impostor_runtime_view.comp and impostor_shadow_caster.frag;
//   - impostorMaterial() of shaders/impostor_material.glsl: reconstruct,
//     the world normal through the object's rotation, the surface point
//     centre + radius * position and its depth (the pixel depth offset);
//   - impostorLambert() of shaders/impostor_material_light.glsl: albedo x
//     (colour x N.L + ambient x occlusion), shadow term 1;
//   - impostorShadowCaster(): the depth variant, alpha-tested, depth offset;
//   - the cross-fade at the LOD switch (shaders/impostor_crossfade.glsl,
//     embedded in impostor_crossfade.glsl.js; compiled in with
//     IMPOSTOR_CROSS_FADE): both variants discard the pixels the instance's
//     (t, seed) gives to the mesh, the depth variant with the shadow map's
//     own pixels, so the shadow fades with the colour.
// Per instance, the vertex stage picks the frames and weights
// (impostorBlendFramesLayout: they depend only on the direction from the
// instance's centre to the camera) and hands them to the fragment stage as
// flat varyings, so an InstancedMesh of any count is one draw call.
// Object space is the manifest's (the glTF scene's, +Y up); modelMatrix (x
// instanceMatrix) places it and must be a similarity (rotation, uniform
// scale, translation). Depth: WebGL's window depth is 0.5 * ndc.z + 0.5
// where Vulkan's is clip.z / clip.w (three's reversed depth buffer uses the
// latter; the logarithmic one its own formula).
import { impostorCrossFadeGlsl } from './impostor_crossfade.glsl.js';
import { impostorRuntimeGlsl } from './impostor_runtime.glsl.js';

// ImpostorMaterial.output, in the uniform's numbering.
export const OUTPUTS = Object.freeze({
  lit: 0, albedo: 1, coverage: 2, normal: 3, orm: 4, 'frame-index': 5, 'blend-weights': 6,
});
export const RECONSTRUCTIONS = Object.freeze({ plain: 0, parallax: 1, depth: 2 });
export const BLENDS = Object.freeze({ triangle3: 0, bilinear4: 1 });

const VERTEX_MAIN = `
uniform vec4 impostorSphere;    // object space: centre xyz, radius w
uniform ivec4 impostorLayout;   // kind, frames, ring_views, tile_size
uniform ivec4 impostorMode;     // blend, reconstruction, has_orm, output
out vec3 vImpostorRayOrigin;    // sphere space: (p - centre) / radius
out vec3 vImpostorRayDir;
flat out ivec4 vImpostorFrames;   // blend entries' frame indices
flat out vec4 vImpostorWeights;   // their weights (0 past the count)
flat out int vImpostorCount;
flat out mat4 vImpostorObjectToWorld;
#ifdef IMPOSTOR_CROSS_FADE
#ifdef USE_INSTANCING
in vec2 impostorFade;           // per instance: t, seed (InstancedImpostorMesh.setFadeAt)
#else
uniform vec2 impostorCrossFade;  // t, seed (ImpostorMaterial.fade, .fadeSeed)
#endif
flat out vec2 vImpostorFade;
#endif
#include <logdepthbuf_pars_vertex>

void main() {
  mat4 objectToWorld = modelMatrix;
#ifdef USE_INSTANCING
  objectToWorld = modelMatrix * instanceMatrix;
#endif
  mat4 worldToObject = inverse(objectToWorld);
  vec3 viewDir;     // object space, centre -> camera
  vec3 eyeSphere;   // the eye in sphere space (perspective)
  if (isOrthographic) {
    // The camera's +Z (its backward axis) is row 2 of the view matrix.
    vec3 backWorld = vec3(viewMatrix[0][2], viewMatrix[1][2], viewMatrix[2][2]);
    viewDir = normalize(mat3(worldToObject) * backWorld);
    eyeSphere = viewDir;
  } else {
    vec3 eyeObject = (worldToObject * vec4(cameraPosition, 1.0)).xyz;
    eyeSphere = (eyeObject - impostorSphere.xyz) / impostorSphere.w;
    viewDir = normalize(eyeSphere);
  }
  ImpostorFrameCamera card = impostorCameraForDirection(viewDir);
  vec3 p = position.x * card.right + position.y * card.up + viewDir;
  vImpostorRayOrigin = p;
  vImpostorRayDir = isOrthographic ? -viewDir : p - eyeSphere;
  ImpostorLayout atlas = ImpostorLayout(impostorLayout.x, impostorLayout.y, impostorLayout.z);
  ImpostorBlend blend = impostorBlendFramesLayout(atlas, viewDir, impostorMode.x);
  vImpostorCount = blend.count;
  vImpostorFrames = ivec4(blend.index[0], blend.index[1], blend.index[2], blend.index[3]);
  vImpostorWeights = vec4(blend.weight[0], blend.weight[1], blend.weight[2], blend.weight[3]);
  vImpostorObjectToWorld = objectToWorld;
#ifdef IMPOSTOR_CROSS_FADE
#ifdef USE_INSTANCING
  vImpostorFade = impostorFade;
#else
  vImpostorFade = impostorCrossFade;
#endif
#endif
  gl_Position = projectionMatrix * viewMatrix * objectToWorld * vec4(impostorSphere.xyz + p * impostorSphere.w, 1.0);
#include <logdepthbuf_vertex>
}`;

// The fragment's blend, rebuilt from the flat varyings (a frame's tile is
// impostorFrameTile of its index for every layout), and its surface.
const FRAGMENT_COMMON = `
// three declares no output for GLSL3 shader materials; its chunks write gl_FragColor.
layout(location = 0) out highp vec4 pc_fragColor;
#define gl_FragColor pc_fragColor
uniform mat4 projectionMatrix;  // three declares it for the vertex stage only
uniform sampler2D impostorAlbedo;
uniform sampler2D impostorNormalDepth;
uniform sampler2D impostorOrm;
uniform vec4 impostorSphere;
uniform ivec4 impostorLayout;
uniform ivec4 impostorMode;
in vec3 vImpostorRayOrigin;
in vec3 vImpostorRayDir;
flat in ivec4 vImpostorFrames;
flat in vec4 vImpostorWeights;
flat in int vImpostorCount;
flat in mat4 vImpostorObjectToWorld;
#ifdef IMPOSTOR_CROSS_FADE
flat in vec2 vImpostorFade;  // t, seed (an integer below 2^24)
#endif
#include <logdepthbuf_pars_fragment>

// Whether the cross-fade gives this pixel to the mesh (never without
// IMPOSTOR_CROSS_FADE). Tested first: a faded-out pixel costs no reconstruction.
bool impostorFadedOut() {
#ifdef IMPOSTOR_CROSS_FADE
  return !impostorCrossFadeDrawsImpostor(vImpostorFade.x, uint(vImpostorFade.y), ivec2(gl_FragCoord.xy));
#else
  return false;
#endif
}

ImpostorBlend impostorVaryingBlend(ImpostorLayout atlas) {
  ImpostorBlend b = impostorEmptyBlend();
  b.count = vImpostorCount;
  for (int i = 0; i < 4; ++i) {
    b.index[i] = vImpostorFrames[i];
    b.weight[i] = vImpostorWeights[i];
    b.frame[i] = impostorFrameTile(atlas, vImpostorFrames[i]);
  }
  return b;
}

// The window depth of a world-space point for the current camera.
float impostorWindowDepth(vec3 world) {
  vec4 clip = projectionMatrix * viewMatrix * vec4(world, 1.0);
#if defined(USE_LOGDEPTHBUF)
  return vIsPerspective == 0.0 ? clamp(0.5 * clip.z / clip.w + 0.5, 0.0, 1.0) : log2(1.0 + clip.w) * logDepthBufFC * 0.5;
#elif defined(USE_REVERSEDEPTHBUF)
  return clamp(clip.z / clip.w, 0.0, 1.0);
#else
  return clamp(0.5 * clip.z / clip.w + 0.5, 0.0, 1.0);
#endif
}

ImpostorSurface impostorFragmentSurface(out ImpostorBlend blend, bool hasOrm) {
  ImpostorLayout atlas = ImpostorLayout(impostorLayout.x, impostorLayout.y, impostorLayout.z);
  blend = impostorVaryingBlend(atlas);
  return impostorReconstructLayout(impostorAlbedo, impostorNormalDepth, impostorOrm, hasOrm, atlas, impostorLayout.w,
                                   blend, vImpostorRayOrigin, vImpostorRayDir, impostorMode.y);
}
`;

const FRAGMENT_MAIN = `
uniform bool impostorDepthOffset;
uniform vec3 impostorTowardLight;  // world, unit
uniform vec4 impostorLight;        // rgb radiance, a = ambient

vec3 impostorIndexColour(int i) {
  uint h = uint(i) * 2654435761u;
  return vec3(float((h >> 16) & 255u), float((h >> 8) & 255u), float(h & 255u)) / 255.0;
}

void main() {
  if (impostorFadedOut()) discard;
  bool hasOrm = impostorMode.z != 0;
  ImpostorBlend blend;
  ImpostorSurface s = impostorFragmentSurface(blend, hasOrm);
  if (s.alpha < 0.5) discard;
  vec3 orm = hasOrm ? s.orm : vec3(0.0, 1.0, 0.0);
  // Normals transform with the inverse transpose; for a similarity that is
  // the rotation part, renormalised.
  vec3 normalWorld = normalize(mat3(vImpostorObjectToWorld) * (s.normal + vec3(0.0, 0.0, 1e-12)));
  vec3 world = (vImpostorObjectToWorld * vec4(impostorSphere.xyz + impostorSphere.w * s.position, 1.0)).xyz;
#ifdef IMPOSTOR_DEPTH_OFFSET
  gl_FragDepth = impostorDepthOffset ? impostorWindowDepth(world) : gl_FragCoord.z;
#endif
  int outputMode = impostorMode.w;
  if (outputMode >= ${OUTPUTS.coverage}) {
    // Debug views: the values themselves, no colour management.
    vec3 v = outputMode == ${OUTPUTS.coverage} ? vec3(1.0)
           : outputMode == ${OUTPUTS.normal} ? normalWorld * 0.5 + 0.5
           : outputMode == ${OUTPUTS.orm} ? orm
           : outputMode == ${OUTPUTS['frame-index']} ? impostorIndexColour(blend.index[0])
           : vec3(blend.weight[0], blend.count > 1 ? blend.weight[1] : 0.0, blend.count > 2 ? blend.weight[2] : 0.0);
    gl_FragColor = vec4(v, 1.0);
    return;
  }
  vec3 c = s.albedo;
  if (outputMode == ${OUTPUTS.lit}) {
    float ndotl = max(dot(normalWorld, impostorTowardLight), 0.0);
    c = s.albedo * (impostorLight.rgb * ndotl + impostorLight.a * orm.x);
  }
  gl_FragColor = vec4(c, 1.0);
  #include <tonemapping_fragment>
  #include <colorspace_fragment>
}`;

// The depth variant (customDepthMaterial): three's shadow pass draws with
// the light's camera, so the card faces the light and, for a directional
// light, every ray runs along it. Packed as three's depth material packs
// RGBA depth.
const DEPTH_MAIN = `
#include <packing>
uniform bool impostorCoverageTest;  // false: the whole card casts (to show what the test does)
void main() {
  if (impostorFadedOut()) discard;
  ImpostorBlend blend;
  ImpostorSurface s = impostorFragmentSurface(blend, false);
  if (impostorCoverageTest && s.alpha < 0.5) discard;
  vec3 world = (vImpostorObjectToWorld * vec4(impostorSphere.xyz + impostorSphere.w * s.position, 1.0)).xyz;
  float depth = impostorCoverageTest ? impostorWindowDepth(world) : gl_FragCoord.z;
  gl_FragDepth = depth;
  gl_FragColor = packDepthToRGBA(depth);
}`;

export const impostorVertexShader = `${impostorRuntimeGlsl}\n${VERTEX_MAIN}`;
export const impostorFragmentShader =
  `${impostorRuntimeGlsl}\n${impostorCrossFadeGlsl}\n${FRAGMENT_COMMON}\n${FRAGMENT_MAIN}`;
export const impostorDepthFragmentShader =
  `${impostorRuntimeGlsl}\n${impostorCrossFadeGlsl}\n${FRAGMENT_COMMON}\n${DEPTH_MAIN}`;
