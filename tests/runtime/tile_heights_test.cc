// TileHeights: its kLanes-wide read is its one-point read, bit for bit, on
// random tiles and points (inside, on and outside the tile's square, and
// non-finite ones), so the reference renderer's march may read four steps
// at once without changing a pixel.
#include "common/runtime/tile_heights.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace impostor {
namespace {

uint32_t Bits(float v) {
  uint32_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}

// An atlas of 3 x 2 tiles of odd size whose texels are random: empty
// (alpha 0) a third of the time, else any alpha and depth.
ImpostorAtlas RandomAtlas(std::mt19937* rng, int tile) {
  ImpostorAtlas atlas;
  atlas.width = 3 * tile;
  atlas.height = 2 * tile;
  const size_t texels = static_cast<size_t>(atlas.width) * atlas.height;
  atlas.albedo_alpha.resize(texels * 4);
  atlas.normal_depth.resize(texels * 4);
  std::uniform_int_distribution<int> byte(0, 255), word(0, 65535), empty(0, 2);
  for (size_t i = 0; i < texels; ++i) {
    atlas.albedo_alpha[i * 4 + 3] = static_cast<uint8_t>(empty(*rng) == 0 ? 0 : byte(*rng));
    atlas.normal_depth[i * 4 + 3] = static_cast<uint16_t>(word(*rng));
  }
  return atlas;
}

TEST(TileHeightsTest, LanesReadWhatSampleReadsToTheBit) {
  std::mt19937 rng(20261203);
  const int tile = 37;
  const ImpostorAtlas atlas = RandomAtlas(&rng, tile);
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  // Points on the square's edges, texel centres and borders, signed zeros
  // and non-finite values, then random ones a little beyond the square.
  std::vector<glm::vec2> points = {{-1, -1}, {1, 1},   {-1, 1},       {1, -1},        {0, 0},         {-0.0f, -0.0f},
                                   {1, 0},   {0, -1},  {1.0000001f, 0}, {0, -1.0000001f}, {nan, 0},      {0, nan},
                                   {inf, 0}, {0, -inf}, {2.5f, 0.5f},   {-7, 3}};
  for (int i = 0; i <= tile; ++i) {  // texel borders and centres along both axes
    const float edge = 2.0f * static_cast<float>(i) / tile - 1.0f;
    const float centre = 2.0f * (static_cast<float>(i) + 0.5f) / tile - 1.0f;
    points.push_back({edge, centre});
    points.push_back({centre, -edge});
  }
  std::uniform_real_distribution<float> coord(-1.1f, 1.1f);
  for (int i = 0; i < 200000; ++i) points.push_back({coord(rng), coord(rng)});
  while (points.size() % kLanes != 0) points.push_back({0.5f, 0.5f});

  int covered = 0;
  for (int t = 0; t < 6; ++t) {
    const TileRect rect{(t % 3) * tile, (t / 3) * tile, tile, tile};
    const TileHeights heights(atlas, rect);
    for (size_t p = 0; p < points.size(); p += kLanes) {
      FloatLanes s, u, alpha, depth, x, y;
      for (int l = 0; l < kLanes; ++l) s[l] = points[p + l].x, u[l] = points[p + l].y;
      heights.SampleLanes(s, u, &alpha, &depth, &x, &y);
      for (int l = 0; l < kLanes; ++l) {
        const glm::vec2 st = points[p + l];
        const TileHeights::AlphaDepth want = heights.Sample(st);
        ASSERT_EQ(Bits(alpha[l]), Bits(want.alpha)) << "tile " << t << " st " << st.x << "," << st.y << " lane " << l;
        ASSERT_EQ(Bits(depth[l]), Bits(want.depth)) << "tile " << t << " st " << st.x << "," << st.y << " lane " << l;
        if (want.alpha > 0.0f) ++covered;
        if (std::abs(st.x) <= 1.0f && std::abs(st.y) <= 1.0f) {
          const glm::vec2 pixel = FrameStToPixel(rect, st) - glm::vec2(rect.x, rect.y);
          ASSERT_EQ(Bits(x[l]), Bits(pixel.x)) << "st " << st.x << "," << st.y;
          ASSERT_EQ(Bits(y[l]), Bits(pixel.y)) << "st " << st.x << "," << st.y;
        }
      }
    }
  }
  EXPECT_GT(covered, 600000) << "most points must read covered texels";
}

}  // namespace
}  // namespace impostor
