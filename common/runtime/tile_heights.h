// TileHeights: one atlas tile's coverage and depth as the reference
// renderer's march and agreement test read them, one point or kLanes points
// at a time.
#ifndef IMPOSTOR_COMMON_RUNTIME_TILE_HEIGHTS_H_
#define IMPOSTOR_COMMON_RUNTIME_TILE_HEIGHTS_H_

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include <glm/vec2.hpp>

#include "common/atlas/frame_camera.h"
#include "common/runtime/reference_renderer.h"
#include "common/runtime/virtual_plane.h"

namespace impostor {

// Several points at once (TileHeights::SampleLanes): GCC's vector
// extension (Clang has it too), SSE2 on x86-64's baseline. Each lane runs
// the scalar code's operations in the scalar code's order, and that
// baseline has no FMA to fuse them differently, so every lane gives
// Sample's bits (TileHeightsTest checks it). 4 lanes measured faster than
// 8 on SSE2 (runtime_bench, depth mode: 20 against 26 ms a view).
inline constexpr int kLanes = 4;  // SampleLanes' transpose is written for 4
typedef float FloatLanes __attribute__((vector_size(kLanes * sizeof(float))));
typedef int32_t IntLanes __attribute__((vector_size(kLanes * sizeof(int32_t))));

inline FloatLanes BroadcastLanes(float v) { return FloatLanes{} + v; }
inline IntLanes BroadcastLanes(int32_t v) { return IntLanes{} + v; }
inline FloatLanes AbsLanes(FloatLanes v) { return v < 0.0f ? -v : v; }

// One blended frame's tile as the march and the agreement test read it:
// per texel the coverage and depth exactly as TileSampler (the reference
// renderer's full sampler, reference_renderer.cc) decodes them, side by side
// in a tile-sized array with a one-texel border repeating the edge, so a
// march step touches one small array instead of two atlas-wide ones and
// needs no clamping or branch per tap. Sample(st) is TileSampler::Sample(
// tile, st)'s alpha and depth to the bit: the taps TileSampler skips (zero
// bilinear weight or zero alpha) add exactly zero here.
class TileHeights {
 public:
  struct AlphaDepth {
    float alpha = 0.0f;  // filtered coverage
    float depth = 1.0f;  // the covered texels' alpha-weighted depth, 0..1
  };

  TileHeights() = default;
  // Copies `tile` of `atlas` (the tile must lie inside it).
  TileHeights(const ImpostorAtlas& atlas, const TileRect& tile);

  // TileSampler::Sample(tile, st)'s alpha and depth: bilinear over the 2x2
  // texel centres around st; alpha 0 and depth 1 outside the tile's square.
  AlphaDepth Sample(glm::vec2 st) const {
    AlphaDepth out;
    if (!(std::abs(st.x) <= 1.0f && std::abs(st.y) <= 1.0f)) return out;
    // ForEachBilinearTap's arithmetic, step for step.
    const glm::vec2 pixel = FrameStToPixel(tile_, st);
    const float fx = pixel.x - static_cast<float>(tile_.x) - 0.5f;
    const float fy = pixel.y - static_cast<float>(tile_.y) - 0.5f;
    const float flx = std::floor(fx);
    const float fly = std::floor(fy);
    // Border index = clamped index + 1; one past either edge reads the
    // border, which repeats the edge as the clamp would.
    const int ix = std::clamp(static_cast<int>(flx), -1, tile_.width - 1) + 1;
    const int iy = std::clamp(static_cast<int>(fly), -1, tile_.height - 1) + 1;
    const float ax = fx - flx;
    const float ay = fy - fly;
    const Texel* row0 = &texels_[static_cast<size_t>(iy) * stride_ + ix];
    const Texel* row1 = row0 + stride_;
    const Texel taps[4] = {row0[0], row0[1], row1[0], row1[1]};
    const float bilinear[4] = {(1 - ax) * (1 - ay), ax * (1 - ay), (1 - ax) * ay, ax * ay};
    float covered = 0.0f;
    float depth = 0.0f;
    for (int k = 0; k < 4; ++k) {
      const float w = bilinear[k] * taps[k].alpha;
      covered += w;
      depth += w * taps[k].depth;
    }
    out.alpha = covered;
    if (covered > 0.0f) out.depth = depth / covered;
    return out;
  }

  // Sample at kLanes points (s[l], t[l]) at once, each lane Sample's alpha
  // and depth to the bit. Also sets (*x, *y) to the points' tile pixel
  // coordinates (CoveredBox's), valid where |s|, |t| <= 1.
  void SampleLanes(FloatLanes s, FloatLanes t, FloatLanes* alpha, FloatLanes* depth, FloatLanes* x,
                   FloatLanes* y) const {
    const IntLanes inside = (AbsLanes(s) <= 1.0f) & (AbsLanes(t) <= 1.0f);
    // Lanes outside read the centre instead: every index stays in the tile.
    s = inside ? s : BroadcastLanes(0.0f);
    t = inside ? t : BroadcastLanes(0.0f);
    const float tx = static_cast<float>(tile_.x), ty = static_cast<float>(tile_.y);
    // FrameStToPixel, then ForEachBilinearTap's arithmetic.
    const FloatLanes px = tx + (s + 1.0f) * 0.5f * static_cast<float>(tile_.width);
    const FloatLanes py = ty + (1.0f - t) * 0.5f * static_cast<float>(tile_.height);
    *x = px - tx;
    *y = py - ty;
    const FloatLanes fx = px - tx - 0.5f;
    const FloatLanes fy = py - ty - 0.5f;
    const FloatLanes flx = Floor(fx), fly = Floor(fy);
    const IntLanes ix = Clamp(__builtin_convertvector(flx, IntLanes), tile_.width - 1) + 1;
    const IntLanes iy = Clamp(__builtin_convertvector(fly, IntLanes), tile_.height - 1) + 1;
    const FloatLanes ax = fx - flx;
    const FloatLanes ay = fy - fly;
    // Each lane's two texel pairs, (alpha, depth, alpha, depth) a row, are
    // one load each; transposed, a[k] and d[k] hold tap k of every lane.
    FloatLanes rows[2][kLanes];
    for (int l = 0; l < kLanes; ++l) {
      const Texel* row0 = &texels_[static_cast<size_t>(iy[l]) * stride_ + ix[l]];
      std::memcpy(&rows[0][l], row0, sizeof(FloatLanes));
      std::memcpy(&rows[1][l], row0 + stride_, sizeof(FloatLanes));
    }
    FloatLanes a[4], d[4];
    for (int r = 0; r < 2; ++r) {
      const FloatLanes* v = rows[r];
      const FloatLanes left01 = __builtin_shufflevector(v[0], v[1], 0, 4, 1, 5);
      const FloatLanes left23 = __builtin_shufflevector(v[2], v[3], 0, 4, 1, 5);
      const FloatLanes right01 = __builtin_shufflevector(v[0], v[1], 2, 6, 3, 7);
      const FloatLanes right23 = __builtin_shufflevector(v[2], v[3], 2, 6, 3, 7);
      a[2 * r] = __builtin_shufflevector(left01, left23, 0, 1, 4, 5);
      d[2 * r] = __builtin_shufflevector(left01, left23, 2, 3, 6, 7);
      a[2 * r + 1] = __builtin_shufflevector(right01, right23, 0, 1, 4, 5);
      d[2 * r + 1] = __builtin_shufflevector(right01, right23, 2, 3, 6, 7);
    }
    const FloatLanes bilinear[4] = {(1 - ax) * (1 - ay), ax * (1 - ay), (1 - ax) * ay, ax * ay};
    FloatLanes covered = BroadcastLanes(0.0f), sum = BroadcastLanes(0.0f);
    for (int k = 0; k < 4; ++k) {
      const FloatLanes w = bilinear[k] * a[k];
      covered += w;
      sum += w * d[k];
    }
    *alpha = inside ? covered : BroadcastLanes(0.0f);
    *depth = (inside & (covered > 0.0f)) ? sum / covered : BroadcastLanes(1.0f);
  }

 private:
  // std::floor for |v| < 2^31, as the scalar code's inline expansion.
  static FloatLanes Floor(FloatLanes v) {
    const FloatLanes truncated = __builtin_convertvector(__builtin_convertvector(v, IntLanes), FloatLanes);
    return truncated > v ? truncated - 1.0f : truncated;
  }
  // std::clamp(i, -1, hi).
  static IntLanes Clamp(IntLanes i, int32_t hi) {
    i = i < -1 ? BroadcastLanes(int32_t{-1}) : i;
    return i > hi ? BroadcastLanes(hi) : i;
  }

  struct Texel {
    float alpha, depth;
  };
  // SampleLanes loads two neighbouring texels as one FloatLanes and
  // transposes four of them.
  static_assert(kLanes == 4 && 2 * sizeof(Texel) == sizeof(FloatLanes));
  TileRect tile_{};
  int stride_ = 0;             // tile.width + 2
  std::vector<Texel> texels_;  // (tile.height + 2) rows of stride_
};

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_RUNTIME_TILE_HEIGHTS_H_
