// LodThresholds: the budget at each switch and the impostor's 16 px rule.
#include "worker/lod/lod_thresholds.h"

#include <cmath>

#include <gtest/gtest.h>

namespace impostor {
namespace {

TEST(LodThresholdsTest, NextLevelErrorProjectsToThePixelBudget) {
  const std::vector<float> errors = {0.0f, 0.001f, 0.01f};
  const std::vector<float> t = LodThresholds(errors, /*radius=*/1.0f, /*pixel_error=*/1.0f);
  ASSERT_EQ(t.size(), 4u);
  EXPECT_FLOAT_EQ(t[0], 1000.0f);  // 0.001 units x 1000 px/unit = 1 px
  EXPECT_FLOAT_EQ(t[1], 100.0f);
  EXPECT_FLOAT_EQ(t[2], 8.0f);     // 16 px over a 2-unit diameter
  EXPECT_EQ(t[3], 0.0f);
  for (size_t i = 0; i + 1 < errors.size(); ++i) {
    EXPECT_NEAR(errors[i + 1] * t[i], 1.0f, 1e-5f) << "switch " << i;
  }
}

TEST(LodThresholdsTest, ShrinkAsErrorGrowsAndScaleWithTheBudget) {
  const std::vector<float> errors = {0.0f, 0.002f, 0.02f};
  const auto t1 = LodThresholds(errors, 1.0f, 1.0f);
  const auto t4 = LodThresholds(errors, 1.0f, 4.0f);
  for (size_t i = 0; i + 1 < t1.size(); ++i) EXPECT_GE(t1[i], t1[i + 1]);
  EXPECT_FLOAT_EQ(t4[0], 4.0f * t1[0]);
}

TEST(LodThresholdsTest, LevelCoarserThanTheImpostorSwitchIsSkipped) {
  // Level 2's error is so large it would only be fine below the impostor's
  // size: level 1 hands over at the impostor's threshold.
  const auto t = LodThresholds(std::vector<float>{0.0f, 0.001f, 1.0f}, 1.0f, 1.0f);
  EXPECT_FLOAT_EQ(t[1], t[2]);
  EXPECT_FLOAT_EQ(t[2], 8.0f);
}

TEST(LodThresholdsTest, ZeroErrorStaysFinite) {
  const auto t = LodThresholds(std::vector<float>{0.0f, 0.0f, 0.01f}, 2.0f, 1.0f);
  EXPECT_TRUE(std::isfinite(t[0]));
  EXPECT_GE(t[0], t[1]);
}

}  // namespace
}  // namespace impostor
