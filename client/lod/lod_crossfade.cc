// Cross-fade at a LOD switch (impostor/lod.h, CROSS-FADE): the band's fade
// factor and the dither that splits pixels between the two levels.
// shaders/impostor_crossfade.glsl is the same dither, operation for
// operation (integer steps, then one exact float division), so the GPU and
// this code agree bit for bit (tests/runtime/glsl_crossfade_test.cc).
// Ordered dithering: B. E. Bayer, "An optimum method for two-level rendition
// of continuous-tone pictures", IEEE ICC 1973.
#include <algorithm>

#include "impostor/lod.h"

namespace impostor::sdk {
namespace {

// The 4 x 4 Bayer matrix, row y & 3, column x & 3: each level 0..15 once per
// aligned block, spread so any t lights an even pattern.
constexpr int kBayer4[4][4] = {{0, 8, 2, 10}, {12, 4, 14, 6}, {3, 11, 1, 9}, {15, 7, 13, 5}};

}  // namespace

float CrossFadeFactor(float pixels_per_unit, float switch_scale, const LodCrossFadeOptions& options) {
  const float band = std::clamp(options.band, 0.0f, 1.0f);
  if (pixels_per_unit <= switch_scale) return 1.0f;
  if (!(band > 0.0f) || !(switch_scale > 0.0f)) return 0.0f;
  // How far into the band from the switch, as a fraction of the band.
  const float above = (pixels_per_unit - switch_scale) / (switch_scale * band);
  return std::clamp(1.0f - above, 0.0f, 1.0f);
}

LodCrossFade SelectLodCrossFade(const LodChain& chain, float pixels_per_unit, const LodCrossFadeOptions& options) {
  LodCrossFade out;
  if (chain.levels.empty()) return out;
  out.level = SelectLodForScale(chain, pixels_per_unit, -1);
  if (out.level + 1 < static_cast<int>(chain.levels.size())) {
    out.t = CrossFadeFactor(pixels_per_unit, chain.levels[out.level].threshold, options);
  }
  return out;
}

float CrossFadeThreshold(uint32_t seed, int x, int y) {
  // Fibonacci hashing (Knuth, TAOCP vol. 3, 6.4): the top bits of seed *
  // 2^32 / phi differ for consecutive seeds.
  const uint32_t offset = (seed * 2654435769u) >> 28;
  const uint32_t level = (static_cast<uint32_t>(kBayer4[y & 3][x & 3]) + offset) & 15u;
  return (static_cast<float>(level) + 0.5f) / 16.0f;
}

bool CrossFadeDrawsImpostor(float t, uint32_t seed, int x, int y) { return CrossFadeThreshold(seed, x, y) < t; }

bool CrossFadeDrawsMesh(float t, uint32_t seed, int x, int y) { return !CrossFadeDrawsImpostor(t, seed, x, y); }

}  // namespace impostor::sdk
