#include "common/request/auto_frames_ladder.h"

#include "absl/strings/str_join.h"
#include "common/atlas/atlas_layout.h"
#include "common/request/bake_request.h"

namespace impostor {
namespace {

constexpr uint32_t kOctahedralCounts[] = {8, 10, 12, 16, 20, 24};
// Odd row counts of about the octahedral ladder's frame totals.
constexpr uint32_t kAzimuthElevationCounts[] = {7, 9, 11, 13, 17, 21};
constexpr uint32_t kRingTopCounts[] = {8, 12, 16, 24, 32, 48};

}  // namespace

std::vector<AutoFramesCandidate> AutoFramesLadderOf(v1::Layout layout) {
  std::vector<AutoFramesCandidate> out;
  switch (layout) {
    case v1::LAYOUT_OCTAHEDRAL:
    case v1::LAYOUT_HEMI_OCTAHEDRAL:
      for (uint32_t f : kOctahedralCounts) out.push_back({.count = f, .frames = f});
      break;
    case v1::LAYOUT_AZIMUTH_ELEVATION:
      for (uint32_t f : kAzimuthElevationCounts) out.push_back({.count = f, .frames = f});
      break;
    case v1::LAYOUT_RING_TOP:
      for (uint32_t k : kRingTopCounts) {
        const ViewLayout v{.kind = LayoutKind::kRingTop, .frames = 0, .ring_views = static_cast<int>(k)};
        out.push_back({.count = k, .frames = static_cast<uint32_t>(GridSide(v)), .ring_views = k});
      }
      break;
    case v1::LAYOUT_BILLBOARD: {
      const ViewLayout v{.kind = LayoutKind::kBillboard, .frames = 0, .ring_views = kBillboardRingViews};
      const auto side = static_cast<uint32_t>(GridSide(v));
      out.push_back({.count = side, .frames = side});
      break;
    }
    default: break;
  }
  return out;
}

std::vector<AutoFramesCandidate> AutoFramesLadder(v1::Layout layout, uint32_t resolution) {
  std::vector<AutoFramesCandidate> out;
  for (const AutoFramesCandidate& c : AutoFramesLadderOf(layout)) {
    if (resolution >= kMinTilePixels * c.frames) out.push_back(c);
  }
  return out;
}

uint32_t AutoFramesMinGridSide(v1::Layout layout) {
  const std::vector<AutoFramesCandidate> ladder = AutoFramesLadderOf(layout);
  return ladder.empty() ? 0 : ladder.front().frames;
}

std::string AutoFramesLadderText(v1::Layout layout) {
  std::vector<uint32_t> counts;
  for (const AutoFramesCandidate& c : AutoFramesLadderOf(layout)) counts.push_back(c.count);
  return absl::StrJoin(counts, ", ");
}

}  // namespace impostor
