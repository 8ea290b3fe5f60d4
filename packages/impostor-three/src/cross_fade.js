// The cross-fade at the LOD switch on the CPU side: the fade factor t for
// an on-screen size (CrossFadeFactor of the C++ SDK, client/include/
// impostor/lod.h) and the dither's per-pixel decision, the same integer
// steps as shaders/impostor_crossfade.glsl (which the material compiles in),
// for deciding on the CPU or checking a rendering.

// The 4 x 4 Bayer matrix, row-major.
const BAYER4 = Object.freeze([0, 8, 2, 10, 12, 4, 14, 6, 3, 11, 1, 9, 15, 7, 13, 5]);

// The default band: a tenth of the switch's screen scale (LodCrossFadeOptions.band).
export const DEFAULT_CROSS_FADE_BAND = 0.1;

// Fade factor at screen scale `pixelsPerUnit` (or any on-screen size) for a
// switch at `switchScale` (the same unit): 0 at or above switchScale * (1 +
// band), 1 at or below switchScale, linear between; band 0..1 (clamped), 0
// is the hard switch.
export function crossFadeFactor(pixelsPerUnit, switchScale, band = DEFAULT_CROSS_FADE_BAND) {
  const b = Math.min(Math.max(band, 0), 1);
  if (pixelsPerUnit <= switchScale) return 1;
  if (!(b > 0) || !(switchScale > 0)) return 0;
  const above = (pixelsPerUnit - switchScale) / (switchScale * b);
  return Math.min(Math.max(1 - above, 0), 1);
}

// The switch from the mesh to the impostor, in pixels per scene unit (the
// unit of crossFadeFactor and the C++ SDK's thresholds): where the bounding
// sphere's diameter covers `goodUpToPixels`, the on-screen size the bake's
// quality pass found the impostor good for (ImpostorAsset.goodUpToPixels,
// manifest quality.good_up_to_pixels), or `fallbackPixels` when the bake did
// not measure one (0); NaN for a radius that is not > 0.
export const DEFAULT_IMPOSTOR_SWITCH_PIXELS = 16;
export function impostorSwitchScale(goodUpToPixels, radius, fallbackPixels = DEFAULT_IMPOSTOR_SWITCH_PIXELS) {
  if (!(radius > 0)) return NaN;
  const pixels = goodUpToPixels > 0 ? goodUpToPixels : fallbackPixels;
  return pixels / (2 * radius);
}

// Dither threshold of pixel (x, y) for instance `seed` (an unsigned 32-bit
// integer): the Bayer level rotated by the top 4 bits of seed * 2654435769,
// as (level + 0.5) / 16.
export function crossFadeThreshold(seed, x, y) {
  const offset = Math.imul(seed >>> 0, 2654435769) >>> 28;
  const level = (BAYER4[(y & 3) * 4 + (x & 3)] + offset) & 15;
  return (level + 0.5) / 16;
}

// Whether the impostor (the coarser level) draws pixel (x, y) at fade t;
// the mesh draws exactly the others.
export function crossFadeDrawsImpostor(t, seed, x, y) { return crossFadeThreshold(seed, x, y) < t; }
export function crossFadeDrawsMesh(t, seed, x, y) { return !crossFadeDrawsImpostor(t, seed, x, y); }
