// Cross-fade at a LOD switch (issue 43): while an object's on-screen size is
// in the band above its switch to the impostor, the engine draws both the
// mesh and the impostor, and each discards a complementary, instance-seeded
// dither of pixels, so the image changes a sixteenth of the pixels at a time
// instead of all at once. The same dither, operation for operation, as
// CrossFadeThreshold / CrossFadeDrawsImpostor / CrossFadeDrawsMesh of the
// C++ SDK (client/include/impostor/lod.h), which also gives t from the
// on-screen size (CrossFadeFactor, SelectLodCrossFade); tests/runtime checks
// the two agree bit for bit. GLSL 4.50 and GLSL ES 3.00 (three.js) alike.
//
// Use, with the same t and seed in both draws of one instance and the pixel
// floor(gl_FragCoord.xy) of the target being drawn (the shadow map's own in
// a shadow pass, so the mesh's and the impostor's shadows split the same way):
//   impostor fragment: if (!impostorCrossFadeDrawsImpostor(t, seed, pixel)) discard;
//   mesh fragment:     if (!impostorCrossFadeDrawsMesh(t, seed, pixel)) discard;
// t = 0: the mesh only; t = 1: the impostor only. Between the two a pixel is
// drawn by exactly one of them; over an aligned 4 x 4 block the impostor's
// share is within 1/32 of t. (Between two mesh levels: "mesh" is the finer.)
#ifndef IMPOSTOR_CROSSFADE_GLSL
#define IMPOSTOR_CROSSFADE_GLSL

// Dither threshold of `pixel` for instance `seed`: the 4 x 4 Bayer level
// (B. E. Bayer, 1973) rotated by the top 4 bits of seed * 2654435769
// (Fibonacci hashing), as (level + 0.5) / 16.
float impostorCrossFadeThreshold(uint seed, ivec2 pixel) {
  const int bayer[16] = int[16](0, 8, 2, 10, 12, 4, 14, 6, 3, 11, 1, 9, 15, 7, 13, 5);
  uint offset = (seed * 2654435769u) >> 28;
  uint level = (uint(bayer[(pixel.y & 3) * 4 + (pixel.x & 3)]) + offset) & 15u;
  return (float(level) + 0.5) / 16.0;
}

bool impostorCrossFadeDrawsImpostor(float t, uint seed, ivec2 pixel) {
  return impostorCrossFadeThreshold(seed, pixel) < t;
}

bool impostorCrossFadeDrawsMesh(float t, uint seed, ivec2 pixel) {
  return !impostorCrossFadeDrawsImpostor(t, seed, pixel);
}

#endif  // IMPOSTOR_CROSSFADE_GLSL
