// SelectLod and friends: the rule documented in impostor/lod.h.
#include <algorithm>
#include <cmath>
#include <limits>

#include "impostor/lod.h"

#include "absl/strings/str_cat.h"

namespace impostor::sdk {

float ScreenScale(float distance, float fov_y_radians, float viewport_height_px) {
  if (!(distance > 0.0f)) return std::numeric_limits<float>::infinity();
  // Same arithmetic as SelectLods, so the batch form equals the single one.
  const float k = viewport_height_px / (2.0f * std::tan(fov_y_radians * 0.5f));
  return k / distance;
}

int SelectLodForScale(const LodChain& chain, float pixels_per_unit, int previous_level,
                      const LodSelectOptions& options) {
  const int n = static_cast<int>(chain.levels.size());
  if (n == 0) return 0;
  int level = n - 1;
  for (int i = 0; i < n - 1; ++i) {
    if (pixels_per_unit >= chain.levels[i].threshold) {
      level = i;
      break;
    }
  }
  if (previous_level < 0 || previous_level >= n || level >= previous_level) return level;
  // Finer than last frame: cross each boundary only with the band's margin.
  const float grow = 1.0f + std::clamp(options.hysteresis, 0.0f, 1.0f);
  int result = previous_level;
  while (result > level && pixels_per_unit >= chain.levels[result - 1].threshold * grow) --result;
  return result;
}

int SelectLod(const LodChain& chain, float distance, float fov_y_radians, float viewport_height_px,
              int previous_level, const LodSelectOptions& options) {
  return SelectLodForScale(chain, ScreenScale(distance, fov_y_radians, viewport_height_px), previous_level,
                           options);
}

absl::Status SelectLods(const LodChain& chain, std::span<const float> distances, float fov_y_radians,
                        float viewport_height_px, std::span<const int> previous_levels, std::span<int> levels,
                        const LodSelectOptions& options) {
  if (distances.size() != previous_levels.size() || distances.size() != levels.size()) {
    return absl::InvalidArgumentError("SelectLods: distances, previous_levels and levels differ in size");
  }
  // The projection factor is shared by every instance.
  const float k = viewport_height_px / (2.0f * std::tan(fov_y_radians * 0.5f));
  for (size_t i = 0; i < distances.size(); ++i) {
    const float s = distances[i] > 0.0f ? k / distances[i] : std::numeric_limits<float>::infinity();
    levels[i] = SelectLodForScale(chain, s, previous_levels[i], options);
  }
  return absl::OkStatus();
}

absl::Status SetImpostorSwitchPixels(LodChain& chain, float diameter_pixels) {
  if (!std::isfinite(diameter_pixels) || diameter_pixels <= 0.0f) {
    return absl::InvalidArgumentError(
        absl::StrCat("SetImpostorSwitchPixels: diameter_pixels ", diameter_pixels, " must be finite and > 0"));
  }
  if (chain.levels.size() < 2 || !(chain.radius > 0.0f)) {
    return absl::InvalidArgumentError("SetImpostorSwitchPixels: the chain has no mesh level or no radius");
  }
  const float threshold = diameter_pixels / (2.0f * chain.radius);
  const size_t last_mesh = chain.levels.size() - 2;
  chain.levels[last_mesh].threshold = threshold;
  // Non-increasing again, from the end: a finer level below the new switch
  // is never drawn.
  for (size_t i = last_mesh; i-- > 0;) {
    chain.levels[i].threshold = std::max(chain.levels[i].threshold, chain.levels[i + 1].threshold);
  }
  return absl::OkStatus();
}

float SwitchDistance(const LodChain& chain, int level, float fov_y_radians, float viewport_height_px) {
  if (level < 0 || level + 1 >= static_cast<int>(chain.levels.size()) || chain.levels[level].threshold <= 0.0f) {
    return std::numeric_limits<float>::infinity();
  }
  return viewport_height_px / (2.0f * std::tan(fov_y_radians * 0.5f) * chain.levels[level].threshold);
}

}  // namespace impostor::sdk
