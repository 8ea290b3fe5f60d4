// The frame counts BakeParameters.frames_auto tries, per layout. Shared by
// request validation (the smallest candidate must fit the resolution) and
// the baker (worker/bake/auto_frames.h), so both see the same ladder. Pure,
// thread-safe.
#ifndef IMPOSTOR_COMMON_REQUEST_AUTO_FRAMES_LADDER_H_
#define IMPOSTOR_COMMON_REQUEST_AUTO_FRAMES_LADDER_H_

#include <cstdint>
#include <string>
#include <vector>

#include "impostor/v1/types.pb.h"

namespace impostor {

// One rung: the parameters a candidate bake sets. `count` is the knob the
// ladder turns and Manifest.quality.frames_tried reports: frames per axis
// for the grid layouts, ring_views for ring-top, 3 for billboard (its 9
// views are fixed, so its ladder has one rung: the bake still measures
// itself against the target and warns when it falls short).
struct AutoFramesCandidate {
  uint32_t count = 0;
  uint32_t frames = 0;      // atlas grid side (BakeParameters.frames)
  uint32_t ring_views = 0;  // ring-top only, else 0
};

// Every rung of `layout`'s ladder, smallest first:
//   octahedral, hemi-octahedral: frames 8, 10, 12, 16, 20, 24;
//   azimuth-elevation: frames 7, 9, 11, 13, 17, 21 (odd: a row at 0 degrees);
//   ring-top: ring_views 8, 12, 16, 24, 32, 48 (grid side 3..7);
//   billboard: 3 (fixed).
// An unknown layout has an empty ladder.
std::vector<AutoFramesCandidate> AutoFramesLadderOf(v1::Layout layout);

// The rungs whose tiles get at least kMinTilePixels at `resolution`
// (resolution >= 8 * frames), smallest first.
std::vector<AutoFramesCandidate> AutoFramesLadder(v1::Layout layout, uint32_t resolution);

// The grid side of the ladder's smallest rung (what request validation
// checks the resolution against); 0 for an unknown layout.
uint32_t AutoFramesMinGridSide(v1::Layout layout);

// "8, 10, 12, 16, 20, 24" (the counts, for messages).
std::string AutoFramesLadderText(v1::Layout layout);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_REQUEST_AUTO_FRAMES_LADDER_H_
