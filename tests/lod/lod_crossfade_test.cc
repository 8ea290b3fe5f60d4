// The cross-fade at a LOD switch (impostor/lod.h, CROSS-FADE): the band's
// fade factor, the level it pairs with, and the dither: complementary at
// every t, the impostor's share of each 4 x 4 block equal to t within 1/32,
// and the documented pattern (the table the three.js package's test checks
// too, tests/web_package/crossfade_test.mjs).
#include <algorithm>
#include <cmath>
#include <cstdint>

#include <gtest/gtest.h>

#include "impostor/lod.h"

namespace impostor::sdk {
namespace {

TEST(CrossFadeTest, FactorRunsFromZeroAboveTheBandToOneAtTheSwitch) {
  const LodCrossFadeOptions o{.band = 0.2f};
  EXPECT_EQ(CrossFadeFactor(200.0f, 100.0f, o), 0.0f);
  EXPECT_NEAR(CrossFadeFactor(120.0f, 100.0f, o), 0.0f, 1e-6f);
  EXPECT_EQ(CrossFadeFactor(120.01f, 100.0f, o), 0.0f);
  EXPECT_NEAR(CrossFadeFactor(115.0f, 100.0f, o), 0.25f, 1e-6f);
  EXPECT_NEAR(CrossFadeFactor(110.0f, 100.0f, o), 0.5f, 1e-6f);
  EXPECT_NEAR(CrossFadeFactor(105.0f, 100.0f, o), 0.75f, 1e-6f);
  EXPECT_EQ(CrossFadeFactor(100.0f, 100.0f, o), 1.0f);
  EXPECT_EQ(CrossFadeFactor(50.0f, 100.0f, o), 1.0f);
  // Monotonic over the band.
  float last = 0.0f;
  for (float s = 130.0f; s >= 90.0f; s -= 0.25f) {
    const float t = CrossFadeFactor(s, 100.0f, o);
    EXPECT_GE(t, last) << "s " << s;
    last = t;
  }
}

TEST(CrossFadeTest, NoBandIsTheHardSwitch) {
  const LodCrossFadeOptions o{.band = 0.0f};
  EXPECT_EQ(CrossFadeFactor(100.001f, 100.0f, o), 0.0f);
  EXPECT_EQ(CrossFadeFactor(100.0f, 100.0f, o), 1.0f);
  // Out of range: clamped to 0..1.
  EXPECT_EQ(CrossFadeFactor(150.0f, 100.0f, {.band = 5.0f}), CrossFadeFactor(150.0f, 100.0f, {.band = 1.0f}));
  EXPECT_EQ(CrossFadeFactor(150.0f, 100.0f, {.band = -1.0f}), 0.0f);
}

TEST(CrossFadeTest, SelectPairsTheLevelWithItsOwnSwitch) {
  LodChain c;
  const float thresholds[] = {400.0f, 40.0f, 0.0f};
  for (int i = 0; i < 3; ++i) {
    LodLevelInfo l;
    l.level = i;
    l.kind = i == 2 ? LodLevelInfo::Kind::kImpostor : LodLevelInfo::Kind::kMesh;
    l.threshold = thresholds[i];
    c.levels.push_back(l);
  }
  const LodCrossFadeOptions o;  // band 0.1
  struct Want {
    float s;
    int level;
    float t;
  };
  for (const Want& w : {Want{1000.0f, 0, 0.0f}, Want{420.0f, 0, 0.5f}, Want{400.0f, 0, 1.0f}, Want{399.0f, 1, 0.0f},
                        Want{42.0f, 1, 0.5f}, Want{40.0f, 1, 1.0f}, Want{10.0f, 2, 0.0f}}) {
    const LodCrossFade f = SelectLodCrossFade(c, w.s, o);
    EXPECT_EQ(f.level, w.level) << "s " << w.s;
    EXPECT_NEAR(f.t, w.t, 1e-5f) << "s " << w.s;
  }
  EXPECT_EQ(SelectLodCrossFade(LodChain{}, 5.0f).level, 0);
}

TEST(CrossFadeTest, DitherIsComplementaryAndSharesEveryBlockByT) {
  for (uint32_t seed : {0u, 1u, 2u, 99u, 0xffffffffu}) {
    for (int k = -4; k <= 68; ++k) {
      const float t = k / 64.0f;
      for (int by = -8; by < 8; by += 4) {
        for (int bx = -8; bx < 8; bx += 4) {
          int impostor = 0;
          for (int y = by; y < by + 4; ++y) {
            for (int x = bx; x < bx + 4; ++x) {
              const bool imp = CrossFadeDrawsImpostor(t, seed, x, y), mesh = CrossFadeDrawsMesh(t, seed, x, y);
              ASSERT_NE(imp, mesh) << "pixel (" << x << ", " << y << ") seed " << seed << " t " << t;
              impostor += imp;
            }
          }
          const float want = std::clamp(t, 0.0f, 1.0f);
          EXPECT_LE(std::abs(impostor / 16.0f - want), 1.0f / 32.0f) << "seed " << seed << " t " << t;
        }
      }
    }
  }
}

// The documented pattern: the Bayer matrix rotated by the top 4 bits of
// seed * 2654435769. Shared with tests/web_package/crossfade_test.mjs.
TEST(CrossFadeTest, PatternIsTheDocumentedOne) {
  struct Row {
    uint32_t seed;
    int levels[4][4];
  };
  const Row rows[] = {
      {0, {{0, 8, 2, 10}, {12, 4, 14, 6}, {3, 11, 1, 9}, {15, 7, 13, 5}}},
      {1, {{9, 1, 11, 3}, {5, 13, 7, 15}, {12, 4, 10, 2}, {8, 0, 6, 14}}},
      {7, {{5, 13, 7, 15}, {1, 9, 3, 11}, {8, 0, 6, 14}, {4, 12, 2, 10}}},
  };
  for (const Row& r : rows) {
    for (int y = 0; y < 4; ++y) {
      for (int x = 0; x < 4; ++x) {
        EXPECT_EQ(CrossFadeThreshold(r.seed, x, y), (r.levels[y][x] + 0.5f) / 16.0f)
            << "seed " << r.seed << " pixel (" << x << ", " << y << ")";
        EXPECT_EQ(CrossFadeThreshold(r.seed, x + 4, y - 8), CrossFadeThreshold(r.seed, x, y)) << "repeats every 4";
      }
    }
  }
}

}  // namespace
}  // namespace impostor::sdk
