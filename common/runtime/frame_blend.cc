#include "common/runtime/frame_blend.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <glm/geometric.hpp>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

struct Corner {
  int dx, dy;
  float weight;
};

// Adds `weight` to `frame`'s canonical entry, merging duplicates.
void Add(LayoutKind layout, int frames, FrameCoord frame, float weight, FrameBlend* blend) {
  if (weight <= 0.0f) return;
  const FrameCoord canonical = CanonicalFrame(layout, frames, frame);
  for (int i = 0; i < blend->count; ++i) {
    if (blend->entries[i].frame == canonical) {
      blend->entries[i].weight += weight;
      return;
    }
  }
  blend->entries[blend->count++] = {canonical, FrameIndex(frames, canonical), weight};
}

}  // namespace

std::string_view BlendModeName(BlendMode mode) {
  switch (mode) {
    case BlendMode::kTriangle3: return "triangle3";
    case BlendMode::kBilinear4: return "bilinear4";
  }
  return "unknown";
}

absl::StatusOr<BlendMode> ParseBlendMode(std::string_view name) {
  if (name == "triangle3") return BlendMode::kTriangle3;
  if (name == "bilinear4") return BlendMode::kBilinear4;
  return absl::InvalidArgumentError(absl::StrCat("blend: unknown blend mode \"", std::string(name),
                                                 "\"; expected \"triangle3\" or \"bilinear4\""));
}

FrameBlend BlendFrames(LayoutKind layout, int frames, glm::vec3 direction, BlendMode mode) {
  FrameBlend blend;
  if (frames <= 1) {
    blend.count = 1;
    blend.entries[0] = {FrameCoord{0, 0}, 0, 1.0f};
    return blend;
  }
  // A zero or non-finite direction has no grid position (and a NaN would
  // reach an int conversion below): treat it as straight up, like the shader.
  const float length2 = glm::dot(direction, direction);
  if (!(length2 > 0.0f) || !std::isfinite(length2)) direction = glm::vec3(0.0f, 1.0f, 0.0f);
  const glm::vec2 grid = DirectionToGrid(layout, frames, direction);
  // The last grid line belongs to the last quad, so fx, fy reach 1 there.
  const int x0 = std::clamp(static_cast<int>(std::floor(grid.x)), 0, frames - 2);
  const int y0 = std::clamp(static_cast<int>(std::floor(grid.y)), 0, frames - 2);
  const float fx = std::clamp(grid.x - static_cast<float>(x0), 0.0f, 1.0f);
  const float fy = std::clamp(grid.y - static_cast<float>(y0), 0.0f, 1.0f);

  std::array<Corner, 4> corners{};
  int n = 0;
  if (mode == BlendMode::kTriangle3) {
    corners[n++] = {0, 0, 1.0f - std::max(fx, fy)};
    if (fx > fy) corners[n++] = {1, 0, fx - fy};
    else corners[n++] = {0, 1, fy - fx};
    corners[n++] = {1, 1, std::min(fx, fy)};
  } else {
    corners[n++] = {0, 0, (1.0f - fx) * (1.0f - fy)};
    corners[n++] = {1, 0, fx * (1.0f - fy)};
    corners[n++] = {0, 1, (1.0f - fx) * fy};
    corners[n++] = {1, 1, fx * fy};
  }
  float total = 0.0f;
  for (int i = 0; i < n; ++i) {
    Add(layout, frames, FrameCoord{x0 + corners[i].dx, y0 + corners[i].dy}, corners[i].weight, &blend);
  }
  // Normalise away float rounding so the weights sum to 1 to the last bit
  // that float allows (they already do mathematically).
  for (int i = 0; i < blend.count; ++i) total += blend.entries[i].weight;
  for (int i = 0; i < blend.count; ++i) blend.entries[i].weight /= total;
  return blend;
}

}  // namespace impostor
