#include "worker/output/supersample.h"

#include <cmath>

#include <gtest/gtest.h>

namespace impostor {
namespace {

// A 4x2 atlas = two 2x2 blocks at factor 2.
AtlasMaps TwoBlocks() {
  AtlasMaps m;
  m.width = 4;
  m.height = 2;
  m.albedo_alpha.assign(4 * 2 * 4, 0);
  m.orm.assign(4 * 2 * 4, 0);
  m.normal_depth.assign(4 * 2 * 4, 0);
  for (int i = 0; i < 8; ++i) {
    m.normal_depth[i * 4 + 0] = m.normal_depth[i * 4 + 1] = m.normal_depth[i * 4 + 2] = 32768;
    m.normal_depth[i * 4 + 3] = 65535;
  }
  return m;
}

void Cover(AtlasMaps* m, int x, int y, uint8_t r, uint8_t g, uint8_t b, float nx, float ny, float nz, uint16_t depth) {
  const size_t i = static_cast<size_t>(y) * m->width + x;
  m->albedo_alpha[i * 4 + 0] = r;
  m->albedo_alpha[i * 4 + 1] = g;
  m->albedo_alpha[i * 4 + 2] = b;
  m->albedo_alpha[i * 4 + 3] = 255;
  const float n[3] = {nx, ny, nz};
  for (int c = 0; c < 3; ++c) m->normal_depth[i * 4 + c] = static_cast<uint16_t>(std::lround((n[c] * 0.5f + 0.5f) * 65535));
  m->normal_depth[i * 4 + 3] = depth;
  m->orm[i * 4 + 0] = 255;
  m->orm[i * 4 + 1] = 100;
  m->orm[i * 4 + 3] = 255;
}

TEST(Supersample, EdgeTexelsKeepTheSurfaceColourAndGetFractionalCoverage) {
  AtlasMaps m = TwoBlocks();
  // Left block: 2 of 4 samples covered, same colour.
  Cover(&m, 0, 0, 200, 100, 50, 0, 0, 1, 1000);
  Cover(&m, 1, 1, 200, 100, 50, 0, 0, 1, 3000);
  ASSERT_TRUE(DownsampleMaps(2, &m).ok());
  ASSERT_EQ(m.width, 2);
  ASSERT_EQ(m.height, 1);
  EXPECT_EQ(m.albedo_alpha[0], 200);  // not darkened toward black
  EXPECT_EQ(m.albedo_alpha[1], 100);
  EXPECT_EQ(m.albedo_alpha[2], 50);
  EXPECT_EQ(m.albedo_alpha[3], 128);  // 2 of 4
  EXPECT_EQ(m.normal_depth[3], 2000);
  EXPECT_EQ(m.orm[1], 100);
  EXPECT_EQ(m.orm[3], 128);
  // Right block: nothing covered -> the empty encodings.
  EXPECT_EQ(m.albedo_alpha[4 + 3], 0);
  EXPECT_EQ(m.normal_depth[4 + 0], 32768);
  EXPECT_EQ(m.normal_depth[4 + 3], 65535);
  EXPECT_EQ(m.orm[4 + 3], 0);
}

TEST(Supersample, ColourIsAveragedInLinearLightAndNormalsRenormalised) {
  AtlasMaps m = TwoBlocks();
  Cover(&m, 0, 0, 255, 255, 255, 1, 0, 0, 0);
  Cover(&m, 1, 0, 0, 0, 0, 0, 1, 0, 0);
  Cover(&m, 0, 1, 255, 255, 255, 1, 0, 0, 0);
  Cover(&m, 1, 1, 0, 0, 0, 0, 1, 0, 0);
  ASSERT_TRUE(DownsampleMaps(2, &m).ok());
  // Half white, half black in linear light is 0.5 -> sRGB 188, not 128.
  EXPECT_EQ(m.albedo_alpha[0], 188);
  EXPECT_EQ(m.albedo_alpha[3], 255);
  const float nx = m.normal_depth[0] / 65535.0f * 2 - 1, ny = m.normal_depth[1] / 65535.0f * 2 - 1;
  EXPECT_NEAR(nx, std::sqrt(0.5f), 1e-3f);
  EXPECT_NEAR(ny, std::sqrt(0.5f), 1e-3f);
}

TEST(Supersample, FactorOneIsIdentityAndBadSizesAreRefused) {
  AtlasMaps m = TwoBlocks();
  Cover(&m, 3, 1, 9, 8, 7, 0, 1, 0, 5);
  const AtlasMaps before = m;
  ASSERT_TRUE(DownsampleMaps(1, &m).ok());
  EXPECT_EQ(m.albedo_alpha, before.albedo_alpha);
  EXPECT_EQ(DownsampleMaps(3, &m).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(DownsampleMaps(0, &m).code(), absl::StatusCode::kInvalidArgument);
  m.orm.pop_back();
  EXPECT_EQ(DownsampleMaps(2, &m).code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace impostor
