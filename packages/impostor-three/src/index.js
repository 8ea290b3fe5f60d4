// impostor-three: draw impostors baked by the impostor bake farm in three.js,
// loaded from a published release with every byte verified.
export { ImpostorLoader, DRAWN_SEMANTICS } from './impostor_loader.js';
export { ImpostorAsset } from './impostor_asset.js';
export { ImpostorMaterial, ImpostorDepthMaterial, DEFAULT_LIGHT_DIRECTION } from './impostor_material.js';
export { ImpostorMesh, InstancedImpostorMesh, ImpostorCardGeometry } from './impostor_mesh.js';
export { LAYOUT_KINDS, atlasLayout, layoutName, productName } from './layout.js';
export { isTextureArray, layerPlacements, repackLayerStrip } from './texture_array.js';
export { impostorRuntimeGlsl } from './shaders/impostor_runtime.glsl.js';
export { impostorCrossFadeGlsl } from './shaders/impostor_crossfade.glsl.js';
export {
  DEFAULT_CROSS_FADE_BAND, crossFadeDrawsImpostor, crossFadeDrawsMesh, crossFadeFactor, crossFadeThreshold,
  DEFAULT_IMPOSTOR_SWITCH_PIXELS, impostorSwitchScale,
} from './cross_fade.js';
export * from './release/index.js';
