// BakeParameters.frames_auto: pick the frame count by measured quality.
//
// The atlas is baked at each count of the layout's fixed ladder
// (common/request/auto_frames_ladder.h: frames per axis for the grid layouts,
// ring_views for ring-top, the fixed 3x3 for billboard; only counts whose
// tiles get at least kMinTilePixels at the requested resolution), smallest
// first, each followed by the quality pass; the first
// whose quality meets auto_target is kept (fewer frames = bigger tiles = more
// detail per frame and less memory, so the smallest acceptable count is the
// best). When none meets it, the largest count tried is kept and
// Manifest.warnings says so. Manifest.quality.frames_tried / frames_met
// report every count tried, in order; Manifest.frames is the grid side kept.
//
// Thread-safety: as BakeAtlas (one bake per AtlasRenderer at a time).
#ifndef IMPOSTOR_WORKER_BAKE_AUTO_FRAMES_H_
#define IMPOSTOR_WORKER_BAKE_AUTO_FRAMES_H_

#include <atomic>
#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "impostor/v1/types.pb.h"
#include "worker/bake/atlas_bake.h"
#include "worker/gpu/atlas_renderer.h"

namespace impostor {

// True when `quality` meets every threshold `target` sets (as
// CheckQualityGate judges a result).
bool MeetsQualityTarget(const v1::QualityGate& target, const v1::AtlasQuality& quality);

// Bakes request.parameters (frames_auto set, frames 0, auto_target with a
// threshold, quality_views > 0: NormalizeParameters guarantees it) as
// described above; the chosen atlas's files end up in request.output_dir as
// BakeAtlas would leave them. INVALID_ARGUMENT when the parameters break
// those rules; BakeAtlas's errors otherwise.
absl::StatusOr<AtlasBakeOutput> BakeAtlasAutoFrames(const AtlasBakeRequest& request, AtlasRenderer& renderer,
                                                    const BakeProgress& progress, const std::atomic<bool>& cancelled);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_BAKE_AUTO_FRAMES_H_
