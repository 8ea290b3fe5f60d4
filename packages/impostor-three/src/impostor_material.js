// ImpostorMaterial: the reference impostor material (shaders/
// impostor_material.glsl over shaders/impostor_runtime.glsl) as a three.js
// ShaderMaterial, for an ImpostorMesh or an InstancedImpostorMesh: 3-frame
// (or 4-frame) blending, virtual-plane UVs, the depth-aware reconstruction
// by default (the mode the farm's quality pass measures), the pixel depth
// offset, and the reference light (one directional light + ambient x
// occlusion, impostor_material_light.glsl). Its `depthMaterial` (an
// ImpostorDepthMaterial sharing its uniforms) is the shadow / depth variant
// the meshes set as customDepthMaterial. With `crossFade` both discard the
// pixels a cross-fade at the LOD switch gives to the mesh
// (shaders/impostor_crossfade.glsl): per instance from an
// InstancedImpostorMesh's setFadeAt, else from `fade` / `fadeSeed`. The asset (and its textures) is
// shared, not owned: dispose() frees the programs, asset.dispose() the maps.
import { Color, DoubleSide, GLSL3, ShaderMaterial, Vector2, Vector3, Vector4 } from 'three';
import {
  BLENDS, OUTPUTS, RECONSTRUCTIONS, impostorDepthFragmentShader, impostorFragmentShader, impostorVertexShader,
} from './shaders/impostor_shaders.js';

// The reference light of the dashboard and the example scene: from
// (1, 2, 1.5), white, ambient 0.25.
export const DEFAULT_LIGHT_DIRECTION = Object.freeze(new Vector3(1, 2, 1.5).normalize());

function pick(table, value, what) {
  if (!(value in table)) throw new TypeError(`${what} "${value}": want one of ${Object.keys(table).join(', ')}`);
  return table[value];
}

function sharedUniforms(asset) {
  const { boundingSphere: s, layout, textures } = asset;
  if (!textures.albedo || !textures.normalDepth) throw new TypeError(`${asset.name}: no albedo_alpha / normal_depth maps to draw`);
  return {
    impostorAlbedo: { value: textures.albedo },
    impostorNormalDepth: { value: textures.normalDepth },
    impostorOrm: { value: textures.orm || textures.albedo },
    impostorSphere: { value: new Vector4(s.center.x, s.center.y, s.center.z, s.radius) },
    impostorLayout: { value: [layout.kind, layout.frames, layout.ringViews, layout.tileSize] },
    // blend, reconstruction, has_orm, output
    impostorMode: { value: [BLENDS[asset.blend], RECONSTRUCTIONS.depth, textures.orm ? 1 : 0, OUTPUTS.lit] },
    // Cross-fade of a non-instanced mesh: t, seed.
    impostorCrossFade: { value: new Vector2(1, 0) },
  };
}

export class ImpostorMaterial extends ShaderMaterial {
  // parameters: {reconstruction: 'depth' | 'parallax' | 'plain' (default
  // 'depth'), blend: 'triangle3' | 'bilinear4' (default: what the asset's
  // quality pass used), output: 'lit' | 'albedo' | 'coverage' | 'normal' |
  // 'orm' | 'frame-index' | 'blend-weights' (default 'lit'; the last five
  // write raw values for debugging), depthOffset (default true),
  // lightDirection (world, toward the light), lightColor, ambient (0.25),
  // crossFade (default false: compiled out), fade (t, default 1: all
  // impostor) and fadeSeed (default 0)} and any ShaderMaterial parameter.
  constructor(asset, parameters = {}) {
    const {
      reconstruction = asset.reconstruction, blend = asset.blend, output = 'lit', depthOffset = true,
      lightDirection = DEFAULT_LIGHT_DIRECTION, lightColor = new Color(1, 1, 1), ambient = 0.25, crossFade = false,
      fade = 1, fadeSeed = 0, ...rest
    } = parameters;
    const uniforms = {
      ...sharedUniforms(asset),
      impostorDepthOffset: { value: true },
      impostorTowardLight: { value: new Vector3() },
      impostorLight: { value: new Vector4() },
    };
    super({
      glslVersion: GLSL3, vertexShader: impostorVertexShader, fragmentShader: impostorFragmentShader, uniforms,
      side: DoubleSide, ...rest,
    });
    this.isImpostorMaterial = true;
    this.type = 'ImpostorMaterial';
    this.asset = asset;
    // The card is drawn facing the camera or the light: both sides, always.
    this.shadowSide = DoubleSide;
    this.lightDirection = new Vector3().copy(lightDirection);
    this.lightColor = new Color().copy(lightColor);
    this.ambient = ambient;
    this.reconstruction = reconstruction;
    this.blend = blend;
    this.output = output;
    this.depthOffset = depthOffset;
    this.depthMaterial = new ImpostorDepthMaterial(this);
    this.crossFade = crossFade;
    this.fade = fade;
    this.fadeSeed = fadeSeed;
  }

  // The cross-fade at the LOD switch, in both variants (another program:
  // IMPOSTOR_CROSS_FADE). Draw the mesh's side with the complementary test
  // (impostorCrossFadeGlsl's impostorCrossFadeDrawsMesh, same t and seed).
  get crossFade() { return 'IMPOSTOR_CROSS_FADE' in this.defines; }
  set crossFade(v) {
    const on = Boolean(v);
    if (on === this.crossFade) return;
    for (const m of [this, this.depthMaterial]) {
      if (on) m.defines.IMPOSTOR_CROSS_FADE = 1;
      else delete m.defines.IMPOSTOR_CROSS_FADE;
      m.needsUpdate = true;
    }
  }

  // A non-instanced mesh's fade factor t (0: only the mesh draws, 1: only
  // the impostor; crossFadeFactor gives it from the on-screen size) and
  // seed (an integer, 0 .. 2^24 - 1). An InstancedImpostorMesh reads its
  // instances' own (setFadeAt).
  get fade() { return this.uniforms.impostorCrossFade.value.x; }
  set fade(t) { this.uniforms.impostorCrossFade.value.x = t; }
  get fadeSeed() { return this.uniforms.impostorCrossFade.value.y; }
  set fadeSeed(seed) { this.uniforms.impostorCrossFade.value.y = seed; }

  get reconstruction() { return this._reconstruction; }
  set reconstruction(v) {
    this.uniforms.impostorMode.value[1] = pick(RECONSTRUCTIONS, v, 'reconstruction');
    this._reconstruction = v;
  }

  get blend() { return this._blend; }
  set blend(v) {
    this.uniforms.impostorMode.value[0] = pick(BLENDS, v, 'blend');
    this._blend = v;
  }

  get output() { return this._output; }
  set output(v) {
    this.uniforms.impostorMode.value[3] = pick(OUTPUTS, v, 'output');
    this._output = v;
  }

  // Off, the program does not write gl_FragDepth at all (another program:
  // IMPOSTOR_DEPTH_OFFSET undefined), so the GPU may test depth before
  // shading: for distant forests, where no impostor meets other geometry.
  get depthOffset() { return this.uniforms.impostorDepthOffset.value; }
  set depthOffset(v) {
    const on = Boolean(v);
    this.uniforms.impostorDepthOffset.value = on;
    if (on === 'IMPOSTOR_DEPTH_OFFSET' in this.defines) return;
    if (on) this.defines.IMPOSTOR_DEPTH_OFFSET = 1;
    else delete this.defines.IMPOSTOR_DEPTH_OFFSET;
    this.needsUpdate = true;
  }

  // Light uniforms follow the properties at every draw.
  onBeforeRender() {
    this.uniforms.impostorTowardLight.value.copy(this.lightDirection).normalize();
    const c = this.lightColor;
    this.uniforms.impostorLight.value.set(c.r, c.g, c.b, this.ambient);
  }

  clone() {
    return new ImpostorMaterial(this.asset, {
      reconstruction: this.reconstruction, blend: this.blend, output: this.output, depthOffset: this.depthOffset,
      lightDirection: this.lightDirection, lightColor: this.lightColor, ambient: this.ambient,
      crossFade: this.crossFade, fade: this.fade, fadeSeed: this.fadeSeed,
    });
  }

  dispose() {
    this.depthMaterial.dispose();
    super.dispose();
  }
}

// The shadow / depth variant of an ImpostorMaterial (impostorShadowCaster):
// the surface seen from the camera it is drawn with (the light's, in a
// shadow pass), discarded below half coverage, its depth offset applied,
// packed as three's RGBA depth. Shares the material's textures, layout,
// blend, reconstruction and cross-fade (the shadow map's pixels split
// between mesh and impostor as the screen's do). Directional and spot
// lights; a point light's shadow (customDistanceMaterial) is not drawn by it.
export class ImpostorDepthMaterial extends ShaderMaterial {
  constructor(material) {
    const u = material.uniforms;
    super({
      glslVersion: GLSL3, vertexShader: impostorVertexShader, fragmentShader: impostorDepthFragmentShader,
      uniforms: {
        impostorAlbedo: u.impostorAlbedo, impostorNormalDepth: u.impostorNormalDepth, impostorOrm: u.impostorOrm,
        impostorSphere: u.impostorSphere, impostorLayout: u.impostorLayout, impostorMode: u.impostorMode,
        impostorCrossFade: u.impostorCrossFade, impostorCoverageTest: { value: true },
      },
      side: DoubleSide,
    });
    this.isImpostorDepthMaterial = true;
    this.type = 'ImpostorDepthMaterial';
  }

  // false: the whole card casts, as a plain quad would (for comparison).
  get coverageTest() { return this.uniforms.impostorCoverageTest.value; }
  set coverageTest(v) { this.uniforms.impostorCoverageTest.value = Boolean(v); }
}
