#include "worker/bake/good_for_size.h"

#include <algorithm>
#include <cmath>

namespace impostor {

std::vector<int> GoodForLadder(int top, int steps_per_octave) {
  std::vector<int> sizes;
  if (top < 2 || steps_per_octave < 1) return sizes;
  const int smallest = std::min(kGoodForSmallestPixels, top / 2);
  for (int k = 0;; ++k) {
    const int s = static_cast<int>(std::lround(smallest * std::exp2(static_cast<double>(k) / steps_per_octave)));
    if (s >= top) break;
    if (sizes.empty() || s > sizes.back()) sizes.push_back(s);
  }
  sizes.push_back(top);
  return sizes;
}

v1::QualityGate GoodForTargets(const v1::BakeParameters& parameters) {
  if (parameters.frames_auto() &&
      (parameters.auto_target().has_min_iou() || parameters.auto_target().has_min_psnr_db())) {
    return parameters.auto_target();
  }
  v1::QualityGate targets;
  targets.set_min_iou(kGoodForMinIou);
  targets.set_min_psnr_db(kGoodForMinPsnrDb);
  return targets;
}

bool MeetsGoodForTargets(const v1::QualityGate& targets, double iou_mean, double psnr_shared_db_mean) {
  if (targets.has_min_iou() && !(iou_mean >= targets.min_iou())) return false;
  if (targets.has_min_psnr_db() && !(psnr_shared_db_mean >= targets.min_psnr_db())) return false;
  return true;
}

uint32_t GoodUpToPixels(const std::vector<v1::SizeQuality>& sizes) {
  uint32_t good = 0;
  for (const v1::SizeQuality& s : sizes) {
    if (!s.meets()) break;
    good = s.pixels();
  }
  return good;
}

}  // namespace impostor
