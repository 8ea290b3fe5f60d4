// The good-for size's pure parts (worker/bake/good_for_size.h): the ladder of
// on-screen sizes, the targets a bake is judged by, and how the largest good
// size is read off the measured sizes.
#include "worker/bake/good_for_size.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>


namespace impostor {
namespace {

TEST(GoodForLadder, StartsAt32EndsAtTheTopAndStepsAtMostTenPercent) {
  const std::vector<int> ladder = GoodForLadder(256);
  ASSERT_GE(ladder.size(), 20u);
  EXPECT_EQ(ladder.front(), 32);
  EXPECT_EQ(ladder.back(), 256);
  for (size_t i = 1; i < ladder.size(); ++i) {
    EXPECT_GT(ladder[i], ladder[i - 1]);
    // 2^(1/8) = 1.0905, plus rounding to whole pixels at the small end
    // (49 -> 54).
    EXPECT_LE(static_cast<double>(ladder[i]) / ladder[i - 1], 1.11) << ladder[i - 1] << " -> " << ladder[i];
  }
}

// The pass measures every half octave, then bisects on the fine ladder: each
// coarse size must be a fine one, or the bisection would skip sizes.
TEST(GoodForLadder, HalfOctavesAreOnTheFineLadder) {
  for (int top : {40, 64, 128, 160, 256, 1024}) {
    const std::vector<int> fine = GoodForLadder(top), coarse = GoodForLadder(top, kGoodForCoarseStepsPerOctave);
    ASSERT_FALSE(coarse.empty());
    for (int s : coarse) EXPECT_NE(std::find(fine.begin(), fine.end(), s), fine.end()) << s << " of top " << top;
  }
  EXPECT_EQ(GoodForLadder(256, kGoodForCoarseStepsPerOctave), (std::vector<int>{32, 45, 64, 91, 128, 181, 256}));
  EXPECT_TRUE(GoodForLadder(256, 0).empty());
}

TEST(GoodForLadder, SmallTopsStartLowerAndDegenerateOnesAreEmpty) {
  const std::vector<int> small = GoodForLadder(40);
  ASSERT_FALSE(small.empty());
  EXPECT_EQ(small.front(), 20);
  EXPECT_EQ(small.back(), 40);
  EXPECT_TRUE(GoodForLadder(1).empty());
  EXPECT_TRUE(GoodForLadder(0).empty());
  EXPECT_EQ(GoodForLadder(2), (std::vector<int>{1, 2}));
}

TEST(GoodForTargets, DefaultsUnlessFramesAutoSetsItsOwn) {
  v1::BakeParameters p;
  v1::QualityGate t = GoodForTargets(p);
  EXPECT_FLOAT_EQ(t.min_iou(), kGoodForMinIou);
  EXPECT_FLOAT_EQ(t.min_psnr_db(), kGoodForMinPsnrDb);
  // auto_target without frames_auto is not a bake's target (and is refused
  // at submit); with it, it is the one the bake was made to meet.
  p.mutable_auto_target()->set_min_iou(0.97f);
  EXPECT_FLOAT_EQ(GoodForTargets(p).min_psnr_db(), kGoodForMinPsnrDb);
  p.set_frames_auto(true);
  t = GoodForTargets(p);
  EXPECT_FLOAT_EQ(t.min_iou(), 0.97f);
  EXPECT_FALSE(t.has_min_psnr_db());
}

TEST(MeetsGoodForTargets, EachSetThresholdJudgesAndNaNNeverMeets) {
  v1::QualityGate t;
  EXPECT_TRUE(MeetsGoodForTargets(t, 0.1, 3.0));
  t.set_min_iou(0.95f);
  t.set_min_psnr_db(28.0f);
  EXPECT_TRUE(MeetsGoodForTargets(t, 0.95f, 28.0f));
  EXPECT_FALSE(MeetsGoodForTargets(t, 0.949, 40.0));
  EXPECT_FALSE(MeetsGoodForTargets(t, 0.99, 27.9));
  EXPECT_FALSE(MeetsGoodForTargets(t, std::numeric_limits<double>::quiet_NaN(), 40.0));
}

std::vector<v1::SizeQuality> Sizes(const std::vector<std::pair<int, bool>>& in) {
  std::vector<v1::SizeQuality> out;
  for (auto [pixels, meets] : in) {
    out.emplace_back().set_pixels(static_cast<uint32_t>(pixels));
    out.back().set_meets(meets);
  }
  return out;
}

TEST(GoodUpToPixels, TheLargestSizeWithEverySmallerOneGood) {
  EXPECT_EQ(GoodUpToPixels(Sizes({{32, true}, {64, true}, {128, false}, {256, false}})), 64u);
  EXPECT_EQ(GoodUpToPixels(Sizes({{32, true}, {64, true}, {128, true}})), 128u);
  // A bad size in the middle ends the range, though a larger one meets.
  EXPECT_EQ(GoodUpToPixels(Sizes({{32, true}, {64, false}, {128, true}})), 32u);
  EXPECT_EQ(GoodUpToPixels(Sizes({{32, false}, {64, true}})), 0u);
  EXPECT_EQ(GoodUpToPixels({}), 0u);
}

}  // namespace
}  // namespace impostor
