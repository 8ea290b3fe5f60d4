#include "worker/output/atlas_dilation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

namespace impostor {
namespace {

constexpr int kW = 16, kH = 8;  // two 8x8 tiles side by side
const std::vector<TileRect> kTiles = {{0, 0, 8, 8}, {8, 0, 8, 8}};

template <typename T>
void Set(std::vector<T>& img, int x, int y, T r, T g, T b, T a) {
  T* p = &img[(static_cast<size_t>(y) * kW + x) * 4];
  p[0] = r, p[1] = g, p[2] = b, p[3] = a;
}

template <typename T>
const T* At(const std::vector<T>& img, int x, int y) {
  return &img[(static_cast<size_t>(y) * kW + x) * 4];
}

TEST(AtlasDilationTest, OneCoveredTexelFillsItsTileOnly) {
  std::vector<uint8_t> img(kW * kH * 4, 0);
  Set<uint8_t>(img, 3, 4, 10, 200, 30, 255);
  ASSERT_TRUE(DilateRgba8(img, kW, kH, kTiles).ok());
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      const uint8_t* p = At(img, x, y);
      if (x < 8) {
        EXPECT_EQ(p[0], 10) << x << "," << y;
        EXPECT_EQ(p[1], 200) << x << "," << y;
        EXPECT_EQ(p[2], 30) << x << "," << y;
        EXPECT_EQ(p[3], (x == 3 && y == 4) ? 255 : 0) << "alpha changed at " << x << "," << y;
      } else {  // the neighbouring tile has no coverage: untouched
        EXPECT_EQ(p[0] | p[1] | p[2] | p[3], 0) << "leaked into tile 1 at " << x << "," << y;
      }
    }
  }
}

TEST(AtlasDilationTest, NeighbouringTilesDoNotMix) {
  std::vector<uint8_t> img(kW * kH * 4, 0);
  Set<uint8_t>(img, 7, 0, 255, 0, 0, 255);  // right edge of tile 0
  Set<uint8_t>(img, 8, 0, 0, 0, 255, 255);  // left edge of tile 1
  ASSERT_TRUE(DilateRgba8(img, kW, kH, kTiles).ok());
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      const uint8_t* p = At(img, x, y);
      if (x < 8) {
        EXPECT_EQ(p[0], 255) << x << "," << y;
        EXPECT_EQ(p[2], 0) << x << "," << y;
      } else {
        EXPECT_EQ(p[0], 0) << x << "," << y;
        EXPECT_EQ(p[2], 255) << x << "," << y;
      }
    }
  }
}

TEST(AtlasDilationTest, MaxDistanceLimitsTheGrowth) {
  std::vector<uint8_t> img(kW * kH * 4, 0);
  Set<uint8_t>(img, 0, 0, 50, 60, 70, 255);
  ASSERT_TRUE(DilateRgba8(img, kW, kH, kTiles, /*max_distance=*/2).ok());
  for (int y = 0; y < 8; ++y) {
    for (int x = 0; x < 8; ++x) {
      const bool filled = x * x + y * y <= 4;  // Euclidean, in texels
      EXPECT_EQ(At(img, x, y)[0], filled ? 50 : 0) << x << "," << y;
    }
  }
}

TEST(AtlasDilationTest, EachEmptyTexelTakesTheNearestCoveredColour) {
  std::vector<uint8_t> img(kW * kH * 4, 0);
  Set<uint8_t>(img, 1, 1, 100, 0, 0, 255);
  Set<uint8_t>(img, 6, 6, 200, 0, 0, 255);
  ASSERT_TRUE(DilateRgba8(img, kW, kH, kTiles).ok());
  for (int y = 0; y < 8; ++y) {
    for (int x = 0; x < 8; ++x) {
      const int d1 = (x - 1) * (x - 1) + (y - 1) * (y - 1);
      const int d2 = (x - 6) * (x - 6) + (y - 6) * (y - 6);
      if (d1 == d2) continue;  // tie: either is right
      EXPECT_EQ(At(img, x, y)[0], d1 < d2 ? 100 : 200) << x << "," << y;
    }
  }
}

TEST(AtlasDilationTest, LargeTileWithSilhouette) {
  // A disc in a 256x256 tile: every empty texel gets the colour of a disc
  // texel at (nearly) the shortest distance.
  const int n = 256;
  std::vector<uint8_t> img(static_cast<size_t>(n) * n * 4, 0);
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      const int dx = x - 128, dy = y - 128;
      if (dx * dx + dy * dy < 50 * 50) {
        uint8_t* p = &img[(static_cast<size_t>(y) * n + x) * 4];
        p[0] = static_cast<uint8_t>(x), p[1] = static_cast<uint8_t>(y), p[3] = 255;
      }
    }
  }
  const std::vector<TileRect> tile = {{0, 0, n, n}};
  ASSERT_TRUE(DilateRgba8(img, n, n, tile).ok());
  for (int y = 0; y < n; y += 7) {
    for (int x = 0; x < n; x += 5) {
      const uint8_t* p = &img[(static_cast<size_t>(y) * n + x) * 4];
      const double d = std::hypot(x - 128.0, y - 128.0);
      if (d < 50) continue;
      // The source texel (p[0], p[1]) is on the disc, about d - 50 away.
      const double src = std::hypot(p[0] - x, p[1] - y);
      EXPECT_LE(src, d - 50 + 1.5) << x << "," << y;
      EXPECT_EQ(p[3], 0);
    }
  }
}

TEST(AtlasDilationTest, Uint16NormalDepthUsesAlbedoCoverage) {
  std::vector<uint8_t> albedo(kW * kH * 4, 0);
  std::vector<uint16_t> nd(kW * kH * 4, 0);
  Set<uint8_t>(albedo, 5, 5, 1, 2, 3, 255);
  Set<uint16_t>(nd, 5, 5, 1000, 40000, 65000, 1234);
  Set<uint16_t>(nd, 12, 3, 7, 7, 7, 7);  // tile 1: uncovered garbage
  ASSERT_TRUE(DilateRgba16(nd, albedo, kW, kH, kTiles).ok());
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      const uint16_t* p = At(nd, x, y);
      if (x == 5 && y == 5) {
        EXPECT_EQ(p[3], 1234);  // covered depth untouched
      } else {
        EXPECT_EQ(p[3], 65535) << "empty depth must read as far at " << x << "," << y;
      }
      if (x < 8) {
        EXPECT_EQ(p[0], 1000);
        EXPECT_EQ(p[1], 40000);
        EXPECT_EQ(p[2], 65000);
      }
    }
  }
  EXPECT_EQ(At(nd, 12, 3)[0], 7);  // tile 1 has no coverage: RGB left alone
}

// An atlas's tiles are filled side by side on the machine's cores: the
// result must be what filling them one at a time gives, texel for texel,
// for RGBA8 and for RGBA16 read through a separate coverage map.
TEST(AtlasDilationTest, TilesFilledSideBySideMatchOneAtATime) {
  constexpr int kSide = 12, kGrid = 6, kSize = kSide * kGrid;
  std::vector<TileRect> tiles;
  for (int ty = 0; ty < kGrid; ++ty) {
    for (int tx = 0; tx < kGrid; ++tx) tiles.push_back({tx * kSide, ty * kSide, kSide, kSide});
  }
  std::vector<uint8_t> rgba(kSize * kSize * 4, 0);
  std::vector<uint16_t> rgba16(kSize * kSize * 4, 0);
  uint32_t x = 12345;
  for (size_t i = 0; i < rgba.size(); i += 4) {
    x = x * 1664525 + 1013904223;
    const bool covered = (x >> 28) < 3;  // about one texel in five
    for (int c = 0; c < 3; ++c) rgba[i + c] = static_cast<uint8_t>(x >> (8 * c));
    rgba[i + 3] = covered ? 255 : 0;
    for (int c = 0; c < 4; ++c) rgba16[i + c] = static_cast<uint16_t>(x >> (4 * c));
  }
  std::vector<uint8_t> expected = rgba;
  std::vector<uint16_t> expected16 = rgba16;
  for (const TileRect& tile : tiles) {
    ASSERT_TRUE(DilateRgba8(expected, kSize, kSize, std::span<const TileRect>(&tile, 1)).ok());
    ASSERT_TRUE(DilateRgba16(expected16, rgba, kSize, kSize, std::span<const TileRect>(&tile, 1)).ok());
  }
  std::vector<uint16_t> got16 = rgba16;
  ASSERT_TRUE(DilateRgba16(got16, rgba, kSize, kSize, tiles).ok());
  ASSERT_TRUE(DilateRgba8(rgba, kSize, kSize, tiles).ok());
  EXPECT_EQ(rgba, expected);
  EXPECT_EQ(got16, expected16);
}

// Tiles that overlap (never an atlas's, but a caller's list may) are filled
// one after another in the order given, as before: the later tile's fill
// wins where both fill a texel.
TEST(AtlasDilationTest, OverlappingTilesAreFilledInOrder) {
  std::vector<uint8_t> img(kW * kH * 4, 0);
  Set<uint8_t>(img, 0, 0, 255, 0, 0, 255);   // red, in both tiles
  Set<uint8_t>(img, 15, 7, 0, 0, 255, 255);  // blue, in the wide tile only
  const std::vector<TileRect> overlapping = {{0, 0, 8, 8}, {0, 0, 16, 8}};
  ASSERT_TRUE(DilateRgba8(img, kW, kH, overlapping).ok());
  // (7, 7) is nearer blue within the wide tile, filled last.
  EXPECT_EQ(At(img, 7, 7)[2], 255);
  EXPECT_EQ(At(img, 7, 7)[0], 0);
  EXPECT_EQ(At(img, 1, 0)[0], 255);
}

TEST(AtlasDilationTest, TilesOutsideTheImageAreRefused) {
  std::vector<uint8_t> img(kW * kH * 4, 0);
  const std::vector<TileRect> bad = {{12, 0, 8, 8}};
  const absl::Status s = DilateRgba8(img, kW, kH, bad);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << s;
  std::vector<uint8_t> small(10);
  EXPECT_EQ(DilateRgba8(small, kW, kH, kTiles).code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace impostor
