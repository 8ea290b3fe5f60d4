#include "common/atlas/atlas_layout.h"

#include <algorithm>
#include <cmath>
#include <initializer_list>

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
    case LayoutKind::kAzimuthElevation: return "azimuth-elevation";
    case LayoutKind::kRingTop: return "ring-top";
    case LayoutKind::kBillboard: return "billboard";
  }
  return "unknown";
}

absl::StatusOr<LayoutKind> ParseLayout(std::string_view name) {
  if (name == "octahedral") return LayoutKind::kOctahedral;
  if (name == "hemi-octahedral") return LayoutKind::kHemiOctahedral;
  if (name == "azimuth-elevation") return LayoutKind::kAzimuthElevation;
  if (name == "ring-top") return LayoutKind::kRingTop;
  if (name == "billboard") return LayoutKind::kBillboard;
  return absl::InvalidArgumentError(absl::StrCat(
      "layout: unknown layout \"", std::string(name),
      "\"; expected octahedral, hemi-octahedral, azimuth-elevation, ring-top or billboard"));
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
  return kind == LayoutKind::kHemiOctahedral ? HemiOctahedralToDirection(oct)
                                             : OctahedralToDirection(oct);
}

glm::vec2 DirectionToLayout(LayoutKind kind, glm::vec3 direction) {
  return kind == LayoutKind::kHemiOctahedral ? DirectionToHemiOctahedral(direction)
                                             : DirectionToOctahedral(direction);
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

namespace {

constexpr float kTwoPi = 6.28318530717958647692f;
constexpr float kPi = 3.14159265358979323846f;

bool IsOctahedral(LayoutKind kind) {
  return kind == LayoutKind::kOctahedral || kind == LayoutKind::kHemiOctahedral;
}

int RingViews(const ViewLayout& layout) {
  return layout.kind == LayoutKind::kBillboard ? kBillboardRingViews : layout.ring_views;
}

float AzimuthElevationRowElevation(int frames, int row) {
  return 0.5f * kPi - (static_cast<float>(row) + 0.5f) * kPi / static_cast<float>(frames);
}

// Index of the nearest of `candidates` (ascending indices) by angle, ties to
// the first: strictly greater dot products win.
int NearestOf(const ViewLayout& layout, glm::vec3 d, std::initializer_list<int> candidates) {
  int best = -1;
  float best_dot = -2.0f;
  for (int i : candidates) {
    const float dot = glm::dot(d, FrameDirectionAt(layout, i));
    if (dot > best_dot) {
      best_dot = dot;
      best = i;
    }
  }
  return best;
}

}  // namespace

glm::vec2 DirectionToAzimuthElevation(glm::vec3 d) {
  d = glm::normalize(d);
  float az = std::atan2(d.x, d.z);
  if (az < 0.0f) az += kTwoPi;
  if (az >= kTwoPi) az = 0.0f;
  return {az, std::asin(std::clamp(d.y, -1.0f, 1.0f))};
}

glm::vec3 AzimuthElevationToDirection(float az, float el) {
  return {std::sin(az) * std::cos(el), std::sin(el), std::cos(az) * std::cos(el)};
}

int FrameCount(const ViewLayout& layout) {
  return IsOctahedral(layout.kind) || layout.kind == LayoutKind::kAzimuthElevation
             ? layout.frames * layout.frames
             : RingViews(layout) + 1;
}

bool IsBakeableLayout(const ViewLayout& layout) {
  const auto in = [](int v, uint32_t lo, uint32_t hi) {
    return v >= static_cast<int>(lo) && v <= static_cast<int>(hi);
  };
  switch (layout.kind) {
    case LayoutKind::kOctahedral:
    case LayoutKind::kHemiOctahedral:
      return in(layout.frames, kMinFrames, kMaxFrames);
    case LayoutKind::kAzimuthElevation:
      return in(layout.frames, kMinFrames, kMaxFrames) && layout.frames % 2 == 1;
    case LayoutKind::kRingTop:
      return in(layout.ring_views, kMinRingViews, kMaxRingViews);
    case LayoutKind::kBillboard:
      return true;  // always 8 views around and one from above
  }
  return false;
}

int GridSide(const ViewLayout& layout) {
  if (IsOctahedral(layout.kind) || layout.kind == LayoutKind::kAzimuthElevation) return layout.frames;
  const int count = RingViews(layout) + 1;
  int side = 1;
  while (side * side < count) ++side;
  return side;
}

glm::vec3 FrameDirectionAt(const ViewLayout& layout, int index) {
  switch (layout.kind) {
    case LayoutKind::kOctahedral:
    case LayoutKind::kHemiOctahedral:
      return FrameDirection(layout.kind, layout.frames, FrameFromIndex(layout.frames, index));
    case LayoutKind::kAzimuthElevation: {
      const FrameCoord f = FrameFromIndex(layout.frames, index);
      const float az = static_cast<float>(f.col) * kTwoPi / static_cast<float>(layout.frames);
      return AzimuthElevationToDirection(az, AzimuthElevationRowElevation(layout.frames, f.row));
    }
    case LayoutKind::kRingTop:
    case LayoutKind::kBillboard: {
      const int k = RingViews(layout);
      if (index >= k) return {0.0f, 1.0f, 0.0f};
      return AzimuthElevationToDirection(static_cast<float>(index) * kTwoPi / static_cast<float>(k), 0.0f);
    }
  }
  return {0.0f, 0.0f, 1.0f};
}

int NearestFrame(const ViewLayout& layout, glm::vec3 direction) {
  const glm::vec3 d = glm::normalize(direction);
  switch (layout.kind) {
    case LayoutKind::kOctahedral:
    case LayoutKind::kHemiOctahedral: {
      // The nearest of the four vertices of the grid cell d falls in.
      const int n = layout.frames;
      const glm::vec2 grid = DirectionToGrid(layout.kind, n, d);
      const int c0 = std::clamp(static_cast<int>(std::floor(grid.x)), 0, n - 2);
      const int r0 = std::clamp(static_cast<int>(std::floor(grid.y)), 0, n - 2);
      const int best = NearestOf(layout, d, {FrameIndex(n, {c0, r0}), FrameIndex(n, {c0 + 1, r0}),
                                             FrameIndex(n, {c0, r0 + 1}), FrameIndex(n, {c0 + 1, r0 + 1})});
      return CanonicalFrameIndex(layout, best);
    }
    case LayoutKind::kAzimuthElevation: {
      // The nearest frame is one of the 2 x 2 grid directions bracketing d:
      // within a row, angle grows with the azimuth difference, and a row
      // beyond the bracketing ones differs more in elevation alone.
      const int n = layout.frames;
      const glm::vec2 ae = DirectionToAzimuthElevation(d);
      const int col0 = std::min(static_cast<int>(std::floor(ae.x * n / kTwoPi)), n - 1);
      const int col1 = (col0 + 1) % n;
      // Row position: 0 at row 0's elevation, growing downward.
      const float row_pos = (0.5f * kPi - ae.y) * n / kPi - 0.5f;
      const int row0 = std::clamp(static_cast<int>(std::floor(row_pos)), 0, n - 1);
      const int row1 = std::min(row0 + 1, n - 1);
      const int a = FrameIndex(n, {col0, row0}), b = FrameIndex(n, {col1, row0});
      const int c = FrameIndex(n, {col0, row1}), e = FrameIndex(n, {col1, row1});
      return NearestOf(layout, d, {std::min(a, b), std::max(a, b), std::min(c, e), std::max(c, e)});
    }
    case LayoutKind::kRingTop:
    case LayoutKind::kBillboard: {
      const int k = RingViews(layout);
      const glm::vec2 ae = DirectionToAzimuthElevation(d);
      const int k0 = std::min(static_cast<int>(std::floor(ae.x * k / kTwoPi)), k - 1);
      const int k1 = (k0 + 1) % k;
      return NearestOf(layout, d, {std::min(k0, k1), std::max(k0, k1), k});
    }
  }
  return 0;
}

int CanonicalFrameIndex(const ViewLayout& layout, int index) {
  if (!IsOctahedral(layout.kind)) return index;
  return FrameIndex(layout.frames,
                    CanonicalFrame(layout.kind, layout.frames, FrameFromIndex(layout.frames, index)));
}

}  // namespace impostor
