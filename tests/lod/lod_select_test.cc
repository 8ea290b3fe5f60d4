// SelectLod: the documented switch distances, the hysteresis band, and the
// batch form.
#include "impostor/lod.h"

#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>

namespace impostor::sdk {
namespace {

constexpr float kFov = 1.0471976f;  // 60 degrees
constexpr float kHeight = 1080.0f;

LodChain Chain() {
  LodChain c;
  const float thresholds[] = {400.0f, 40.0f, 8.0f, 0.0f};
  for (int i = 0; i < 4; ++i) {
    LodLevelInfo l;
    l.level = i;
    l.kind = i == 3 ? LodLevelInfo::Kind::kImpostor : LodLevelInfo::Kind::kMesh;
    l.threshold = thresholds[i];
    c.levels.push_back(l);
  }
  c.radius = 1.0f;
  return c;
}

// Issue 43: a caller moves the impostor's switch (the baker put it at the
// size the impostor is good for); finer levels below the new switch are
// skipped, and bad sizes are refused.
TEST(SelectLodTest, TheCallerMovesTheImpostorSwitch) {
  LodChain c = Chain();  // radius 1: threshold = diameter_pixels / 2
  ASSERT_TRUE(SetImpostorSwitchPixels(c, 20.0f).ok());
  EXPECT_FLOAT_EQ(c.levels[2].threshold, 10.0f);
  EXPECT_FLOAT_EQ(c.levels[1].threshold, 40.0f);
  EXPECT_EQ(SelectLodForScale(c, 9.0f, -1), 3);
  EXPECT_EQ(SelectLodForScale(c, 11.0f, -1), 2);
  // Past lod1's own switch (40): lod1 hands over straight to the impostor,
  // lod2 is never drawn.
  ASSERT_TRUE(SetImpostorSwitchPixels(c, 100.0f).ok());
  EXPECT_FLOAT_EQ(c.levels[2].threshold, 50.0f);
  EXPECT_FLOAT_EQ(c.levels[1].threshold, 50.0f);
  EXPECT_FLOAT_EQ(c.levels[0].threshold, 400.0f);
  EXPECT_EQ(SelectLodForScale(c, 500.0f, -1), 0);
  EXPECT_EQ(SelectLodForScale(c, 60.0f, -1), 1);
  EXPECT_EQ(SelectLodForScale(c, 49.0f, -1), 3);
  for (float bad : {0.0f, -5.0f, std::nanf(""), std::numeric_limits<float>::infinity()}) {
    EXPECT_EQ(SetImpostorSwitchPixels(c, bad).code(), absl::StatusCode::kInvalidArgument) << bad;
  }
  LodChain only_impostor;
  only_impostor.levels.resize(1);
  only_impostor.radius = 1.0f;
  EXPECT_EQ(SetImpostorSwitchPixels(only_impostor, 16.0f).code(), absl::StatusCode::kInvalidArgument);
}

TEST(SelectLodTest, SwitchDistanceFollowsTheDocumentedRule) {
  const LodChain c = Chain();
  const float k = kHeight / (2.0f * std::tan(kFov / 2.0f));
  for (int i = 0; i < 3; ++i) {
    EXPECT_FLOAT_EQ(SwitchDistance(c, i, kFov, kHeight), k / c.levels[i].threshold) << "level " << i;
  }
  EXPECT_TRUE(std::isinf(SwitchDistance(c, 3, kFov, kHeight)));
}

TEST(SelectLodTest, SwitchesDownAtEachThresholdWithoutHistory) {
  const LodChain c = Chain();
  EXPECT_EQ(SelectLod(c, 0.0f, kFov, kHeight, -1), 0);
  for (int i = 0; i < 3; ++i) {
    const float d = SwitchDistance(c, i, kFov, kHeight);
    EXPECT_EQ(SelectLod(c, d * 0.99f, kFov, kHeight, -1), i) << "just inside level " << i;
    EXPECT_EQ(SelectLod(c, d * 1.01f, kFov, kHeight, -1), i + 1) << "just past level " << i;
  }
  EXPECT_EQ(SelectLod(c, 1e9f, kFov, kHeight, -1), 3);
}

TEST(SelectLodTest, ComesBackOnlyPastTheHysteresisBand) {
  const LodChain c = Chain();
  for (int i = 0; i < 3; ++i) {
    const float d = SwitchDistance(c, i, kFov, kHeight);
    // Coarser level drawn last frame, object just inside level i's range:
    // still inside the band, so it stays.
    EXPECT_EQ(SelectLod(c, d * 0.95f, kFov, kHeight, i + 1), i + 1) << "boundary " << i;
    // Closer than d / 1.1: back to level i.
    EXPECT_EQ(SelectLod(c, d / 1.1f * 0.999f, kFov, kHeight, i + 1), i) << "boundary " << i;
    // Going down is not delayed: past d the coarser level is used at once.
    EXPECT_EQ(SelectLod(c, d * 1.001f, kFov, kHeight, i), i + 1) << "boundary " << i;
  }
  // A custom band.
  const float d0 = SwitchDistance(c, 0, kFov, kHeight);
  EXPECT_EQ(SelectLod(c, d0 / 1.3f, kFov, kHeight, 1, {.hysteresis = 0.5f}), 1);
  EXPECT_EQ(SelectLod(c, d0 / 1.6f, kFov, kHeight, 1, {.hysteresis = 0.5f}), 0);
}

TEST(SelectLodTest, DoesNotToggleInsideTheBand) {
  const LodChain c = Chain();
  const float d = SwitchDistance(c, 1, kFov, kHeight);
  int level = -1, changes = 0;
  // An object that wobbles around the boundary, within +-4%.
  for (int frame = 0; frame < 200; ++frame) {
    const float dist = d * (1.0f + 0.04f * std::sin(frame * 0.7f));
    const int next = SelectLod(c, dist, kFov, kHeight, level);
    if (level >= 0 && next != level) ++changes;
    level = next;
  }
  EXPECT_LE(changes, 1) << "one switch down at most, never back inside the band";
}

TEST(SelectLodTest, JumpsSeveralLevelsAtOnce) {
  const LodChain c = Chain();
  EXPECT_EQ(SelectLod(c, 1e6f, kFov, kHeight, 0), 3);
  EXPECT_EQ(SelectLod(c, 0.01f, kFov, kHeight, 3), 0);
}

TEST(SelectLodTest, BatchEqualsSingle) {
  const LodChain c = Chain();
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> dist(0.0f, 300.0f);
  std::uniform_int_distribution<int> prev(-1, 3);
  std::vector<float> distances(10000);
  std::vector<int> previous(distances.size()), levels(distances.size());
  for (size_t i = 0; i < distances.size(); ++i) {
    distances[i] = dist(rng);
    previous[i] = prev(rng);
  }
  ASSERT_TRUE(SelectLods(c, distances, kFov, kHeight, previous, levels).ok());
  for (size_t i = 0; i < distances.size(); ++i) {
    ASSERT_EQ(levels[i], SelectLod(c, distances[i], kFov, kHeight, previous[i])) << "instance " << i;
  }
  // In place.
  std::vector<int> in_place = previous;
  ASSERT_TRUE(SelectLods(c, distances, kFov, kHeight, in_place, in_place).ok());
  EXPECT_EQ(in_place, levels);
}

TEST(SelectLodTest, BatchRefusesMismatchedSpans) {
  const LodChain c = Chain();
  std::vector<float> d(3);
  std::vector<int> p(2), l(3);
  EXPECT_EQ(SelectLods(c, d, kFov, kHeight, p, l).code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace impostor::sdk
