// The reference impostor material (shaders/impostor_material.glsl, issue 22)
// as a three.js RawShaderMaterial, so the dashboard draws an impostor the
// way an engine does: lit from the baked normals and with the pixel depth
// offset (gl_FragDepth from the atlas depth), in one three.js scene with
// other geometry, so a ground plane cuts it where it cuts the mesh.
//
// What it mirrors, function by function:
//   - the card and the sphere-space ray: shaders/impostor_runtime_check.vert
//     (as impostor_gl.js);
//   - impostorMaterial() of impostor_material.glsl: blend, shade with
//     parallax, the surface point centre + radius * position, its depth;
//   - impostorLambert() of impostor_material_light.glsl: albedo x (colour x
//     N.L + ambient x occlusion). The impostor receives no shadow (shadow
//     term 1), as the mesh in the viewer does not;
//   - impostorShadowCaster() of impostor_material.glsl: the card's
//     customDepthMaterial, so three.js's shadow pass draws the impostor as
//     seen from the light (card facing the light, parallel rays, alpha test,
//     the surface point's depth), packed as three's depth material packs it.
// The runtime functions are shaders/impostor_runtime.glsl itself, served at
// /runtime/impostor_runtime.glsl. Object space = world space (the impostor is
// drawn where the mesh is). WebGL's window depth is 0.5 * ndc.z + 0.5 where
// Vulkan's is clip.z / clip.w: the only deviation from the GLSL.
import * as THREE from 'three';
import { decodeKtx2Rgba, isKtx2 } from './ktx2_rgba.js';
import { decodeLayerStrip, isTextureArray } from './texture_array.js';

const LAYOUT_KIND = {
  LAYOUT_OCTAHEDRAL: 0, LAYOUT_UNSPECIFIED: 0, LAYOUT_HEMI_OCTAHEDRAL: 1, LAYOUT_AZIMUTH_ELEVATION: 2,
  LAYOUT_RING_TOP: 3, LAYOUT_BILLBOARD: 4,
};

const PRECISION = 'precision highp float;\nprecision highp int;\nprecision highp sampler2D;\n';

// The card's corner gl_VertexID (two triangles), one radius out toward
// `facing`, in sphere space.
const CARD = `
vec3 impostorCardCorner(vec3 facing) {
  vec2 corners[6] = vec2[6](vec2(-1, -1), vec2(1, -1), vec2(1, 1), vec2(-1, -1), vec2(1, 1), vec2(-1, 1));
  ImpostorFrameCamera card = impostorCameraForDirection(facing);
  vec2 c = corners[gl_VertexID];
  return c.x * card.right + c.y * card.up + facing;
}`;

const VERTEX = `
uniform mat4 projectionMatrix;
uniform mat4 viewMatrix;
uniform vec3 u_eye;     // eye, radius units from the centre
uniform vec4 u_sphere;  // centre xyz, radius w
out vec3 v_ray_origin;
out vec3 v_ray_dir;
void main() {
  vec3 p = impostorCardCorner(normalize(u_eye));
  v_ray_origin = p;
  v_ray_dir = p - u_eye;
  gl_Position = projectionMatrix * viewMatrix * vec4(u_sphere.xyz + p * u_sphere.w, 1.0);
}`;

const FRAGMENT = `
uniform mat4 projectionMatrix;
uniform mat4 viewMatrix;
uniform vec3 u_eye;
uniform vec4 u_sphere;
uniform sampler2D u_albedo;
uniform sampler2D u_normal_depth;
uniform sampler2D u_orm;
uniform ivec4 u_layout;  // kind, frames, ring_views, tile_size
uniform ivec4 u_mode;    // blend mode, has_orm, lit, depth offset
uniform int u_mask;      // 1: flat white (tests compare silhouettes), 2: normal_world * 0.5 + 0.5,
                         // 3: the ORM in use (tests relight)
uniform vec3 u_toward_light;  // world, unit
uniform vec4 u_light;         // rgb radiance, a = ambient
in vec3 v_ray_origin;
in vec3 v_ray_dir;
out vec4 o_color;
vec3 srgbEncode(vec3 c) {
  c = clamp(c, 0.0, 1.0);
  return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}
void main() {
  // impostorMaterial(): parallax on, as the example scene's default.
  ImpostorLayout atlas = ImpostorLayout(u_layout.x, u_layout.y, u_layout.z);
  ImpostorBlend blend = impostorBlendFramesLayout(atlas, normalize(u_eye), u_mode.x);
  ImpostorSurface s = impostorShadeLayout(u_albedo, u_normal_depth, u_orm, u_mode.y != 0, atlas, u_layout.w, blend,
                                          v_ray_origin, v_ray_dir, true);
  if (s.alpha < 0.5) discard;
  vec3 orm = u_mode.y != 0 ? s.orm : vec3(0.0, 1.0, 0.0);
  vec3 normal_world = normalize(s.normal + vec3(0.0, 0.0, 1e-12));
  vec3 world = u_sphere.xyz + u_sphere.w * s.position;
  vec4 clip = projectionMatrix * viewMatrix * vec4(world, 1.0);
  // The pixel depth offset; off keeps the card's own depth (to show what it fixes).
  gl_FragDepth = u_mode.w != 0 ? clamp(0.5 * clip.z / clip.w + 0.5, 0.0, 1.0) : gl_FragCoord.z;
  // impostorLambert() with the shadow term 1.
  float ndotl = max(dot(normal_world, u_toward_light), 0.0);
  vec3 lit = s.albedo * (u_light.rgb * ndotl + u_light.a * orm.x);
  vec3 c = u_mode.z != 0 ? lit : s.albedo;
  o_color = u_mask == 1 ? vec4(1.0) : u_mask == 2 ? vec4(normal_world * 0.5 + 0.5, 1.0) :
            u_mask == 3 ? vec4(orm, 1.0) : vec4(srgbEncode(c), 1.0);
}`;

// The shadow pass: the card faces the light and every ray runs along it
// (a directional light's orthographic camera), as impostor_shadow_caster.frag.
const SHADOW_VERTEX = `
uniform mat4 projectionMatrix;
uniform mat4 viewMatrix;
uniform vec3 u_toward_light;
uniform vec4 u_sphere;
out vec3 v_ray_origin;
void main() {
  vec3 p = impostorCardCorner(u_toward_light);
  v_ray_origin = p;
  gl_Position = projectionMatrix * viewMatrix * vec4(u_sphere.xyz + p * u_sphere.w, 1.0);
}`;

const SHADOW_FRAGMENT = `
#include <packing>
uniform mat4 projectionMatrix;
uniform mat4 viewMatrix;
uniform vec3 u_toward_light;
uniform vec4 u_sphere;
uniform sampler2D u_albedo;
uniform sampler2D u_normal_depth;
uniform ivec4 u_layout;
uniform ivec4 u_mode;        // x: blend mode
uniform int u_alpha_test;    // 0: the whole card casts (tests show what the test catches)
in vec3 v_ray_origin;
out vec4 o_color;
void main() {
  ImpostorLayout atlas = ImpostorLayout(u_layout.x, u_layout.y, u_layout.z);
  ImpostorBlend blend = impostorBlendFramesLayout(atlas, u_toward_light, u_mode.x);
  ImpostorSurface s = impostorShadeLayout(u_albedo, u_normal_depth, u_albedo, false, atlas, u_layout.w, blend,
                                          v_ray_origin, -u_toward_light, true);
  if (u_alpha_test != 0 && s.alpha < 0.5) discard;
  vec4 clip = projectionMatrix * viewMatrix * vec4(u_sphere.xyz + u_sphere.w * s.position, 1.0);
  float depth = u_alpha_test != 0 ? clamp(0.5 * clip.z / clip.w + 0.5, 0.0, 1.0) : gl_FragCoord.z;
  gl_FragDepth = depth;
  o_color = packDepthToRGBA(depth);
}`;

async function loadTexture(url, srgb, manifest) {
  let tex;
  if (isKtx2(url) || isTextureArray(manifest)) {
    // RGBA8, as a PNG decodes; a texture-array strip laid out as the atlas (texture_array.js).
    const { width, height, data } = isKtx2(url) ? await decodeKtx2Rgba(url) : await decodeLayerStrip(url, manifest);
    tex = new THREE.DataTexture(data, width, height, THREE.RGBAFormat, THREE.UnsignedByteType);
  } else {
    const response = await fetch(url);
    if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
    const image = await createImageBitmap(await response.blob(), { premultiplyAlpha: 'none', colorSpaceConversion: 'none' });
    tex = new THREE.Texture(image);
  }
  tex.flipY = false;
  tex.premultiplyAlpha = false;
  tex.generateMipmaps = false;  // texelFetch only: the runtime filters by hand
  tex.minFilter = THREE.NearestFilter;
  tex.magFilter = THREE.NearestFilter;
  tex.colorSpace = srgb ? THREE.SRGBColorSpace : THREE.NoColorSpace;  // SRGB8_ALPHA8: linear reads
  tex.needsUpdate = true;
  return tex;
}

// The default light: the viewer's sun direction, white, ambient 0.25.
export const DEFAULT_LIGHT = { towardLight: new THREE.Vector3(1, 2, 1.5).normalize(), colour: [1, 1, 1], ambient: 0.25 };

// Returns a THREE.Mesh (the card) whose material draws the impostor and
// whose customDepthMaterial casts its shadow (set card.castShadow); options
// {lit, depthOffset, mask, blend, shadowAlphaTest} are read at every render.
export async function createImpostorMaterialMesh(manifest, fileUrl, light = DEFAULT_LIGHT) {
  const runtime = await (await fetch('/runtime/impostor_runtime.glsl')).text();
  const mapFile = (semantic) => manifest.maps.find((m) => m.semantic === semantic);
  const albedo = mapFile('albedo_alpha');
  const normalDepth = mapFile('normal_depth');
  const orm = mapFile('orm');
  if (!albedo || !normalDepth) throw new Error('this result has no albedo_alpha/normal_depth maps to draw');
  const [albedoTex, normalTex, ormTex] = await Promise.all([loadTexture(fileUrl(albedo.file), true, manifest),
    loadTexture(fileUrl(normalDepth.file), false, manifest),
    orm ? loadTexture(fileUrl(orm.file), false, manifest) : Promise.resolve(null)]);
  const kind = LAYOUT_KIND[manifest.layout] ?? 0;
  const ringViews = kind === 3 ? manifest.views.length - 1 : kind === 4 ? 8 : 0;
  const centre = new THREE.Vector3(...manifest.bounding_sphere.center);
  const radius = manifest.bounding_sphere.radius;
  const options = { lit: true, depthOffset: true, mask: 0, shadowAlphaTest: true,
    blend: manifest.quality && manifest.quality.blend === 'bilinear4' ? 1 : 0 };
  const uniforms = {
    u_eye: { value: new THREE.Vector3() },
    u_sphere: { value: new THREE.Vector4(centre.x, centre.y, centre.z, radius) },
    u_albedo: { value: albedoTex },
    u_normal_depth: { value: normalTex },
    u_orm: { value: ormTex || albedoTex },
    u_layout: { value: [kind, manifest.frames, ringViews, manifest.tile_size] },
    u_mode: { value: [0, 0, 0, 0] },
    u_mask: { value: 0 },
    u_toward_light: { value: light.towardLight.clone() },
    u_light: { value: new THREE.Vector4(...light.colour, light.ambient) },
  };
  const material = new THREE.RawShaderMaterial({
    glslVersion: THREE.GLSL3,
    vertexShader: PRECISION + runtime + CARD + VERTEX,
    fragmentShader: PRECISION + runtime + FRAGMENT,
    uniforms,
    side: THREE.DoubleSide,
  });
  const shadowUniforms = {
    u_toward_light: uniforms.u_toward_light, u_sphere: uniforms.u_sphere, u_albedo: uniforms.u_albedo,
    u_normal_depth: uniforms.u_normal_depth, u_layout: uniforms.u_layout, u_mode: uniforms.u_mode,
    u_alpha_test: { value: 1 },
  };
  const shadowCaster = new THREE.RawShaderMaterial({
    glslVersion: THREE.GLSL3,
    vertexShader: PRECISION + runtime + CARD + SHADOW_VERTEX,
    fragmentShader: PRECISION + runtime + SHADOW_FRAGMENT,
    uniforms: shadowUniforms,
    side: THREE.DoubleSide,
  });
  const geometry = new THREE.BufferGeometry();
  // Six vertices; the shader places them (gl_VertexID), the positions are unused.
  geometry.setAttribute('position', new THREE.Float32BufferAttribute(new Float32Array(18), 3));
  const card = new THREE.Mesh(geometry, material);
  card.frustumCulled = false;
  card.customDepthMaterial = shadowCaster;
  card.onBeforeRender = (renderer, scene, camera) => {
    uniforms.u_eye.value.copy(camera.position).sub(centre).divideScalar(radius);
    uniforms.u_mode.value = [options.blend, ormTex ? 1 : 0, options.lit ? 1 : 0, options.depthOffset ? 1 : 0];
    uniforms.u_mask.value = Number(options.mask);
  };
  // The shadow pass may run before the card's own draw in a frame.
  card.onBeforeShadow = () => {
    uniforms.u_mode.value = [options.blend, ormTex ? 1 : 0, options.lit ? 1 : 0, options.depthOffset ? 1 : 0];
    shadowUniforms.u_alpha_test.value = options.shadowAlphaTest ? 1 : 0;
  };
  card.userData.options = options;
  return card;
}
