#include "common/atlas_layout.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

// sign() that never returns 0, so a direction on an axis has one image.
float SignNotZero(float v) { return v < 0.0f ? -1.0f : 1.0f; }

// Rounds half up, the same way on every platform and in the shaders
// (floor(x + 0.5)), so a direction on a cell boundary picks one side.
int RoundHalfUp(float v) { return static_cast<int>(std::floor(v + 0.5f)); }

}  // namespace

std::string_view LayoutName(LayoutKind kind) {
  switch (kind) {
    case LayoutKind::kOctahedral: return "octahedral";
    case LayoutKind::kHemiOctahedral: return "hemi-octahedral";
  }
  return "unknown";
}

absl::StatusOr<LayoutKind> ParseLayout(std::string_view name) {
  if (name == "octahedral") return LayoutKind::kOctahedral;
  if (name == "hemi-octahedral") return LayoutKind::kHemiOctahedral;
  return absl::InvalidArgumentError(absl::StrCat(
      "layout: unknown layout \"", std::string(name), "\"; expected \"octahedral\" or \"hemi-octahedral\""));
}

glm::vec3 OctahedralToDirection(glm::vec2 oct) {
  glm::vec3 d(oct.x, 1.0f - std::abs(oct.x) - std::abs(oct.y), oct.y);
  if (d.y < 0.0f) {
    const float x = (1.0f - std::abs(oct.y)) * SignNotZero(oct.x);
    const float z = (1.0f - std::abs(oct.x)) * SignNotZero(oct.y);
    d.x = x;
    d.z = z;
  }
  return glm::normalize(d);
}

glm::vec2 DirectionToOctahedral(glm::vec3 d) {
  d /= (std::abs(d.x) + std::abs(d.y) + std::abs(d.z));
  if (d.y >= 0.0f) return {d.x, d.z};
  return {(1.0f - std::abs(d.z)) * SignNotZero(d.x), (1.0f - std::abs(d.x)) * SignNotZero(d.z)};
}

glm::vec3 HemiOctahedralToDirection(glm::vec2 oct) {
  const float x = (oct.x + oct.y) * 0.5f;
  const float z = (oct.x - oct.y) * 0.5f;
  return glm::normalize(glm::vec3(x, 1.0f - std::abs(x) - std::abs(z), z));
}

glm::vec2 DirectionToHemiOctahedral(glm::vec3 d) {
  d.y = std::max(d.y, 0.0f);
  const float sum = std::abs(d.x) + d.y + std::abs(d.z);
  if (sum == 0.0f) return {0.0f, 0.0f};
  d /= sum;
  return {d.x + d.z, d.x - d.z};
}

glm::vec3 LayoutToDirection(LayoutKind kind, glm::vec2 oct) {
  return kind == LayoutKind::kOctahedral ? OctahedralToDirection(oct)
                                         : HemiOctahedralToDirection(oct);
}

glm::vec2 DirectionToLayout(LayoutKind kind, glm::vec3 direction) {
  return kind == LayoutKind::kOctahedral ? DirectionToOctahedral(direction)
                                         : DirectionToHemiOctahedral(direction);
}

glm::vec2 DirectionToGrid(LayoutKind kind, int frames, glm::vec3 direction) {
  const glm::vec2 oct = DirectionToLayout(kind, direction);
  const float scale = static_cast<float>(frames - 1);
  return glm::clamp((oct * 0.5f + 0.5f) * scale, glm::vec2(0.0f), glm::vec2(scale));
}

glm::vec3 FrameDirection(LayoutKind kind, int frames, FrameCoord frame) {
  const float inv = frames > 1 ? 1.0f / static_cast<float>(frames - 1) : 0.0f;
  const glm::vec2 uv(static_cast<float>(frame.col) * inv, static_cast<float>(frame.row) * inv);
  return LayoutToDirection(kind, uv * 2.0f - 1.0f);
}

FrameCoord CanonicalFrame(LayoutKind kind, int frames, FrameCoord frame) {
  if (kind != LayoutKind::kOctahedral || frames < 2) return frame;
  const int last = frames - 1;
  const bool on_border = frame.col == 0 || frame.row == 0 || frame.col == last || frame.row == last;
  if (!on_border) return frame;
  // Corners are all the -Y pole: frame (0, 0) shows it.
  const bool corner = (frame.col == 0 || frame.col == last) && (frame.row == 0 || frame.row == last);
  if (corner) return {0, 0};
  // An edge folds onto itself mirrored about its midpoint.
  FrameCoord mirror = frame;
  if (frame.col == 0 || frame.col == last) mirror.row = last - frame.row;
  else mirror.col = last - frame.col;
  return FrameIndex(frames, mirror) < FrameIndex(frames, frame) ? mirror : frame;
}

FrameCoord EncodeFrame(LayoutKind kind, int frames, glm::vec3 direction) {
  const glm::vec2 grid = DirectionToGrid(kind, frames, direction);
  const int last = frames - 1;
  FrameCoord f{std::clamp(RoundHalfUp(grid.x), 0, last), std::clamp(RoundHalfUp(grid.y), 0, last)};
  return CanonicalFrame(kind, frames, f);
}

}  // namespace impostor
