// The on-screen size an impostor is good for (issue 43): the quality pass
// draws held-out views again at a ladder of sizes, each as a game shows it
// there (the mesh at 3 x 3 samples; the impostor with one sample where its
// tiles are magnified, filtered as mip levels would be where they are
// minified), so a game learns
// the largest size at which this bake still meets its targets: below it,
// switch from the mesh (or its LOD chain) to the impostor. (Shrinking one
// large render instead was cheaper but read 1-1.5 dB high against a direct
// measurement: the shrink antialiases the impostor, which a game does not.)
//
// The targets are the request's auto_target when frames_auto sets one (it is
// part of the bake's parameters, hence of its cache key), else the defaults
// below. The request's gate is not used: it is not part of the cache key,
// and one result answers every request with the same key.
//
// Pure; thread-safe.
#ifndef IMPOSTOR_WORKER_BAKE_GOOD_FOR_SIZE_H_
#define IMPOSTOR_WORKER_BAKE_GOOD_FOR_SIZE_H_

#include <cstdint>
#include <vector>

#include "impostor/v1/types.pb.h"

namespace impostor {

// Default good-for targets, judged on the means over the held-out views as
// QualityGate is: every silhouette within a few percent of the mesh's, and
// colour where both cover at 28 dB (about 4 of 255 levels RMS: a difference
// a player does not see on a distant object). docs/quality.md "Good for".
inline constexpr float kGoodForMinIou = 0.95f;
inline constexpr float kGoodForMinPsnrDb = 28.0f;
// The smallest size judged; below it an impostor is a few dozen pixels and
// any bake will do.
inline constexpr int kGoodForSmallestPixels = 32;
// Steps of the ladder per doubling: 2^(1/8), about 9 %, so a recorded size
// is within 10 % of where a finer sweep would put the switch.
inline constexpr int kGoodForStepsPerOctave = 8;

// Held-out views measured at each size (the first of the pass's): the
// sizes cost several times the pass's own views, and on a CPU device
// (lavapipe) the pass must stay a fraction of the bake.
inline constexpr int kGoodForViews = 4;
// At most this many impostor samples a side per pixel stand in for the mip
// levels a game samples where the tiles are minified (quality_pass.cc).
inline constexpr int kGoodForMaxFilter = 4;
// The pass first measures every half octave (steps_per_octave 2: 32, 45,
// 64, 91, 128, 181, 256), then bisects between the last good size and the
// first bad one on the fine ladder.
inline constexpr int kGoodForCoarseStepsPerOctave = 2;

// Sizes, smallest first: kGoodForSmallestPixels (or top / 2 when top is
// smaller than twice it) times 2^(k / steps_per_octave), rounded, up to
// `top`, which is always the last. Every coarse size (2 per octave) is on
// the fine ladder (8). Empty for top < 2.
std::vector<int> GoodForLadder(int top, int steps_per_octave = kGoodForStepsPerOctave);

// The targets this bake is judged by (top of this file).
v1::QualityGate GoodForTargets(const v1::BakeParameters& parameters);

// Whether one size's figures meet `targets` (unset thresholds pass). The
// IoU is the one outside the mesh's own edge (SilhouetteIouOutsideEdge,
// common/quality/image_metrics.h): a silhouette cannot be asked to agree
// with the mesh's more closely than the mesh's own antialiasing decides.
bool MeetsGoodForTargets(const v1::QualityGate& targets, double iou_mean, double psnr_shared_db_mean);

// The largest size such that it and every smaller size in `sizes` (smallest
// first) meet: one bad size in the middle ends the range, since a game
// switching below a size expects every smaller one to be good too. 0 when
// the smallest does not meet or there are none.
uint32_t GoodUpToPixels(const std::vector<v1::SizeQuality>& sizes);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_BAKE_GOOD_FOR_SIZE_H_
