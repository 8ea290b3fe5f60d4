// Type declarations of impostor-three (written by hand; the JavaScript in
// this folder is the implementation).
import {
  BufferGeometry, Color, InstancedMesh, Loader, LoadingManager, Mesh, ShaderMaterial, ShaderMaterialParameters, Sphere,
  Texture, Vector3, WebGLRenderer,
} from 'three';
import { KTX2Loader } from 'three/examples/jsm/loaders/KTX2Loader.js';
import { CacheStorageLike, ReleaseClient } from './release/index.js';

export * from './release/index.js';

export type LayoutName = 'octahedral' | 'hemi-octahedral' | 'azimuth-elevation' | 'ring-top' | 'billboard';
export type Reconstruction = 'depth' | 'parallax' | 'plain';
export type BlendMode = 'triangle3' | 'bilinear4';
export type ImpostorOutput = 'lit' | 'albedo' | 'coverage' | 'normal' | 'orm' | 'frame-index' | 'blend-weights';

/** IMPOSTOR_LAYOUT_* of shaders/impostor_runtime.glsl, by layout name. */
export const LAYOUT_KINDS: Readonly<Record<LayoutName, number>>;

export interface AtlasLayout {
  kind: number;
  name: LayoutName;
  /** The manifest's `frames`: frames per axis, or the grid side (ring-top, billboard). */
  frames: number;
  /** ring-top: K; billboard: 8; others 0. */
  ringViews: number;
  tileSize: number;
  viewCount: number;
  /** Tiles per atlas side. */
  side: number;
}

/** "hemi-octahedral" for "hemi-octahedral" or "LAYOUT_HEMI_OCTAHEDRAL". */
export function layoutName(layout: string | undefined | null): string;
/** "lod-chain" for "lod-chain" or "PRODUCT_LOD_CHAIN"; "atlas" when absent. */
export function productName(product: string | undefined | null): string;
/** The layout of a manifest; throws a TypeError naming what does not fit. */
export function atlasLayout(manifest: any): AtlasLayout;
/** Whether the result's maps are texture-array layer strips. */
export function isTextureArray(manifest: any): boolean;
/** Where each layer of a texture-array strip goes in the atlas; `side`: the grid side (AtlasLayout.side). */
export function layerPlacements(manifest: any, side?: number): {
  placements: Array<{ layer: [number, number, number, number]; tile: [number, number] }>; side: number;
};
/** The atlas (RGBA8, rows top first) a texture-array strip holds, laid out as the viewer samples it. */
export function repackLayerStrip(image: ImageBitmap, manifest: any, side: number, what: string):
  { width: number; height: number; data: Uint8Array };
/** shaders/impostor_runtime.glsl, the reference runtime. */
export const impostorRuntimeGlsl: string;
/** shaders/impostor_crossfade.glsl: impostorCrossFadeDrawsImpostor / impostorCrossFadeDrawsMesh (t, uint seed, ivec2 pixel), for the mesh's side of a cross-fade. */
export const impostorCrossFadeGlsl: string;
/** The cross-fade band's default: 0.1 of the switch's screen scale. */
export const DEFAULT_CROSS_FADE_BAND: number;
/** Fade factor t: 0 at or above switchScale * (1 + band), 1 at or below switchScale, linear between (any on-screen size unit). */
export function crossFadeFactor(pixelsPerUnit: number, switchScale: number, band?: number): number;
/** The switch size used when a bake measured no good-for size: 16 px, the C++ SDK's fixed rule. */
export const DEFAULT_IMPOSTOR_SWITCH_PIXELS: number;
/** The mesh-to-impostor switch in pixels per scene unit: (goodUpToPixels, else fallbackPixels) / (2 * radius); NaN for radius <= 0. */
export function impostorSwitchScale(goodUpToPixels: number, radius: number, fallbackPixels?: number): number;
/** The dither threshold of pixel (x, y) for an instance's seed: one of (level + 0.5) / 16. */
export function crossFadeThreshold(seed: number, x: number, y: number): number;
/** Whether the impostor draws pixel (x, y) at fade t (threshold < t). */
export function crossFadeDrawsImpostor(t: number, seed: number, x: number, y: number): boolean;
/** Whether the mesh draws pixel (x, y) at fade t: exactly the pixels the impostor does not. */
export function crossFadeDrawsMesh(t: number, seed: number, x: number, y: number): boolean;

export interface ImpostorFileReport {
  name: string;
  semantic: string;
  sha256: string;
  sizeBytes: number;
  /** true when the bytes were checked against their SHA-256 (always, from a release). */
  verified: boolean;
  /** 'cache': Cache Storage; 'network': a mirror; 'given': parseAsync's caller. */
  source: 'cache' | 'network' | 'given';
  url: string;
}

/** One baked impostor ready to draw. Owns its textures. */
export class ImpostorAsset {
  readonly isImpostorAsset: true;
  /** The asset name in the catalog (or the cache key). */
  name: string;
  /** The result's cache key. */
  key: string;
  manifest: any;
  product: string;
  layout: AtlasLayout;
  layoutName: string;
  /** Object space (the manifest's, +Y up). */
  boundingSphere: Sphere;
  textures: { albedo: Texture; normalDepth: Texture; orm: Texture | null };
  files: ImpostorFileReport[];
  catalog: { channel: string; catalogSha256: string } | null;
  /** The quality pass's blend: the material's default. */
  blend: BlendMode;
  /** The on-screen size (bounding-sphere diameter, px) up to which the impostor meets its targets (manifest quality.good_up_to_pixels); 0 when not measured. Switch below it: impostorSwitchScale. */
  goodUpToPixels: number;
  reconstruction: Reconstruction;
  dispose(): void;
}

/** The maps the material reads: albedo_alpha, normal_depth, orm. */
export const DRAWN_SEMANTICS: readonly string[];

/** A three.js Loader of impostors from a published release. */
export class ImpostorLoader extends Loader<ImpostorAsset, string> {
  constructor(manager?: LoadingManager);
  mirrors: string[];
  channel: string | null;
  /** The base URL of a release tree (the directory that holds v1/). */
  setMirror(url: string): this;
  /** Mirrors tried in order for every file. */
  setMirrors(urls: string[]): this;
  setChannel(name: string): this;
  /** Refuse catalogs not signed by this Ed25519 key (raw 32 bytes, base64 or PEM). */
  setPublicKey(key: Uint8Array | ArrayBuffer | string | null): this;
  /** Default 'impostor-blobs-v1'. */
  setCacheName(name: string): this;
  /** Default: the global `caches`; null keeps nothing. */
  setCacheStorage(cacheStorage: CacheStorageLike | null): this;
  setKTX2Loader(loader: KTX2Loader): this;
  /** Where three's examples/jsm/libs/basis/ is served; default: from the import map. */
  setTranscoderPath(path: string): this;
  /** KTX2 maps transcode to a GPU format the renderer supports (else to RGBA8). */
  detectSupport(renderer: WebGLRenderer): this;
  readonly client: ReleaseClient;
  /** onProgress gets a ProgressEvent of the bytes taken from the network against the files' total. */
  load(name: string, onLoad?: (asset: ImpostorAsset) => void, onProgress?: (event: ProgressEvent) => void,
    onError?: (error: unknown) => void): void;
  loadAsync(name: string, onProgress?: (event: ProgressEvent) => void): Promise<ImpostorAsset>;
  /**
   * An asset from a manifest and its maps' bytes (by file name), e.g. a farm result's. Maps whose manifest
   * entry has a digest are checked against it where WebCrypto is available (ImpostorIntegrityError on a mismatch).
   */
  parseAsync(manifest: any, files: Map<string, ArrayBuffer | Uint8Array> | Record<string, ArrayBuffer | Uint8Array>,
    name?: string): Promise<ImpostorAsset>;
  dispose(): void;
}

/** Toward (1, 2, 1.5), normalised. */
export const DEFAULT_LIGHT_DIRECTION: Readonly<Vector3>;

export interface ImpostorMaterialParameters extends ShaderMaterialParameters {
  /** Default 'depth' (what the quality pass measures). */
  reconstruction?: Reconstruction;
  /** Default: the asset's quality pass blend, else 'triangle3'. */
  blend?: BlendMode;
  /** Default 'lit'. The last five write raw values for debugging. */
  output?: ImpostorOutput;
  /** Write the surface point's depth (gl_FragDepth). Default true; false compiles the write out, so the GPU may test depth before shading (distant forests). */
  depthOffset?: boolean;
  /** World space, toward the light. Default DEFAULT_LIGHT_DIRECTION. */
  lightDirection?: Vector3;
  /** Default white. */
  lightColor?: Color;
  /** Ambient x occlusion. Default 0.25. */
  ambient?: number;
  /** Cross-fade at the LOD switch in both variants (IMPOSTOR_CROSS_FADE). Default false (compiled out). */
  crossFade?: boolean;
  /** A non-instanced mesh's fade t (0: none of the impostor, 1: all). Default 1. */
  fade?: number;
  /** A non-instanced mesh's dither seed, an integer below 2^24. Default 0. */
  fadeSeed?: number;
}

/** The reference impostor material (shaders/impostor_material.glsl). */
export class ImpostorMaterial extends ShaderMaterial {
  constructor(asset: ImpostorAsset, parameters?: ImpostorMaterialParameters);
  readonly isImpostorMaterial: true;
  asset: ImpostorAsset;
  reconstruction: Reconstruction;
  blend: BlendMode;
  output: ImpostorOutput;
  depthOffset: boolean;
  lightDirection: Vector3;
  lightColor: Color;
  ambient: number;
  crossFade: boolean;
  fade: number;
  fadeSeed: number;
  /** The shadow / depth variant (the meshes' customDepthMaterial). */
  readonly depthMaterial: ImpostorDepthMaterial;
  clone(): this;
}

/** The shadow / depth variant: alpha-tested, depth offset applied, RGBA-packed depth. */
export class ImpostorDepthMaterial extends ShaderMaterial {
  constructor(material: ImpostorMaterial);
  readonly isImpostorDepthMaterial: true;
  /** false: the whole card casts. Default true. */
  coverageTest: boolean;
}

/** The card geometry; its bounds are the asset's bounding sphere. */
export class ImpostorCardGeometry extends BufferGeometry {
  constructor(asset: ImpostorAsset);
}

/** One impostor. */
export class ImpostorMesh extends Mesh<ImpostorCardGeometry, ImpostorMaterial> {
  constructor(asset: ImpostorAsset, material?: ImpostorMaterial | ImpostorMaterialParameters);
  readonly isImpostorMesh: true;
  asset: ImpostorAsset;
}

/** Any number of impostors in one draw call; frames chosen per instance in the vertex shader. */
export class InstancedImpostorMesh extends InstancedMesh<ImpostorCardGeometry, ImpostorMaterial> {
  constructor(asset: ImpostorAsset, count: number, material?: ImpostorMaterial | ImpostorMaterialParameters);
  readonly isInstancedImpostorMesh: true;
  asset: ImpostorAsset;
  /** Instance `index`'s cross-fade t and seed (default: the index); needs material.crossFade. */
  setFadeAt(index: number, t: number, seed?: number): this;
  getFadeAt(index: number): [number, number];
}
