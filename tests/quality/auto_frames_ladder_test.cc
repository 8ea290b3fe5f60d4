// The frames_auto ladder of every layout (common/request/auto_frames_ladder.h): the
// counts each tries, the grid each count bakes, and which fit a resolution.
#include "common/request/auto_frames_ladder.h"

#include <vector>

#include <gtest/gtest.h>

#include "common/atlas/atlas_layout.h"
#include "common/request/bake_request.h"

namespace impostor {
namespace {

std::vector<uint32_t> Counts(const std::vector<AutoFramesCandidate>& ladder) {
  std::vector<uint32_t> out;
  for (const AutoFramesCandidate& c : ladder) out.push_back(c.count);
  return out;
}

std::vector<uint32_t> Grids(const std::vector<AutoFramesCandidate>& ladder) {
  std::vector<uint32_t> out;
  for (const AutoFramesCandidate& c : ladder) out.push_back(c.frames);
  return out;
}

TEST(AutoFramesLadderTest, EveryLayoutHasItsLadder) {
  using V = std::vector<uint32_t>;
  for (v1::Layout l : {v1::LAYOUT_OCTAHEDRAL, v1::LAYOUT_HEMI_OCTAHEDRAL}) {
    EXPECT_EQ(Counts(AutoFramesLadderOf(l)), (V{8, 10, 12, 16, 20, 24}));
    EXPECT_EQ(Grids(AutoFramesLadderOf(l)), (V{8, 10, 12, 16, 20, 24}));
  }
  const auto az = AutoFramesLadderOf(v1::LAYOUT_AZIMUTH_ELEVATION);
  EXPECT_EQ(Counts(az), (V{7, 9, 11, 13, 17, 21}));
  for (const AutoFramesCandidate& c : az) {
    EXPECT_EQ(c.frames % 2, 1u) << "an odd row count puts a row at 0 degrees";
    EXPECT_EQ(c.ring_views, 0u);
  }
  const auto ring = AutoFramesLadderOf(v1::LAYOUT_RING_TOP);
  EXPECT_EQ(Counts(ring), (V{8, 12, 16, 24, 32, 48}));
  EXPECT_EQ(Grids(ring), (V{3, 4, 5, 5, 6, 7})) << "ceil(sqrt(ring_views + 1))";
  for (const AutoFramesCandidate& c : ring) {
    EXPECT_EQ(c.ring_views, c.count);
    EXPECT_GE(c.frames * c.frames, c.ring_views + 1) << "the grid holds the ring and the top view";
  }
  const auto billboard = AutoFramesLadderOf(v1::LAYOUT_BILLBOARD);
  ASSERT_EQ(billboard.size(), 1u) << "billboard's 9 views are fixed";
  EXPECT_EQ(billboard[0].frames, 3u);
  EXPECT_EQ(billboard[0].ring_views, 0u);
  EXPECT_TRUE(AutoFramesLadderOf(v1::LAYOUT_UNSPECIFIED).empty());
  EXPECT_TRUE(AutoFramesLadderOf(static_cast<v1::Layout>(99)).empty());
}

TEST(AutoFramesLadderTest, OnlyCountsWithTilesOfEightPixelsFit) {
  using V = std::vector<uint32_t>;
  EXPECT_EQ(Counts(AutoFramesLadder(v1::LAYOUT_OCTAHEDRAL, 80)), (V{8, 10}));
  EXPECT_EQ(Counts(AutoFramesLadder(v1::LAYOUT_OCTAHEDRAL, 2048)), (V{8, 10, 12, 16, 20, 24}));
  EXPECT_EQ(Counts(AutoFramesLadder(v1::LAYOUT_AZIMUTH_ELEVATION, 80)), (V{7, 9}));
  EXPECT_EQ(Counts(AutoFramesLadder(v1::LAYOUT_RING_TOP, 40)), (V{8, 12, 16, 24})) << "grid 3..5 at 40 px";
  EXPECT_EQ(Counts(AutoFramesLadder(v1::LAYOUT_BILLBOARD, 24)), (V{3}));
  EXPECT_TRUE(AutoFramesLadder(v1::LAYOUT_BILLBOARD, 23).empty());
  EXPECT_TRUE(AutoFramesLadder(v1::LAYOUT_OCTAHEDRAL, 63).empty());
  // Request validation checks the smallest rung against kMinResolution, so
  // every layout's ladder has a rung at the smallest resolution allowed.
  for (v1::Layout l : {v1::LAYOUT_OCTAHEDRAL, v1::LAYOUT_HEMI_OCTAHEDRAL, v1::LAYOUT_AZIMUTH_ELEVATION,
                       v1::LAYOUT_RING_TOP, v1::LAYOUT_BILLBOARD}) {
    EXPECT_FALSE(AutoFramesLadder(l, kMinResolution).empty()) << static_cast<int>(l);
    EXPECT_EQ(AutoFramesMinGridSide(l), AutoFramesLadderOf(l).front().frames);
  }
  EXPECT_EQ(AutoFramesMinGridSide(v1::LAYOUT_UNSPECIFIED), 0u);
}

TEST(AutoFramesLadderTest, TextListsTheCounts) {
  EXPECT_EQ(AutoFramesLadderText(v1::LAYOUT_OCTAHEDRAL), "8, 10, 12, 16, 20, 24");
  EXPECT_EQ(AutoFramesLadderText(v1::LAYOUT_RING_TOP), "8, 12, 16, 24, 32, 48");
  EXPECT_EQ(AutoFramesLadderText(v1::LAYOUT_BILLBOARD), "3");
  EXPECT_EQ(AutoFramesLadderText(v1::LAYOUT_UNSPECIFIED), "");
}

}  // namespace
}  // namespace impostor
