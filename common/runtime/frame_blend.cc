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

constexpr float kPi = 3.14159265358979323846f;
constexpr float kTwoPi = 6.28318530717958647692f;

// Adds `weight` to frame `index` of a non-octahedral layout (no fold: every
// frame is canonical), merging repeats.
void AddIndex(const ViewLayout& layout, int index, float weight, FrameBlend* blend) {
  if (weight <= 0.0f) return;
  for (int i = 0; i < blend->count; ++i) {
    if (blend->entries[i].index == index) {
      blend->entries[i].weight += weight;
      return;
    }
  }
  blend->entries[blend->count++] = {FrameTile(layout, index), index, weight};
}

void Normalize(FrameBlend* blend) {
  // Normalise away float rounding so the weights sum to 1 to the last bit
  // that float allows (they already do mathematically).
  float total = 0.0f;
  for (int i = 0; i < blend->count; ++i) total += blend->entries[i].weight;
  for (int i = 0; i < blend->count; ++i) blend->entries[i].weight /= total;
}

FrameBlend SingleFrame() {
  FrameBlend blend;
  blend.count = 1;
  blend.entries[0] = {FrameCoord{0, 0}, 0, 1.0f};
  return blend;
}

// atan2(y, x) in plain arithmetic, written out identically in the shader
// (impostorAtan2): GLSL's atan may be off by up to 4096 ULP on a Vulkan
// device (lavapipe's is off by ~6e-6 rad), which would move weights by more
// than the 1e-5 the shader and this code agree to. The octant is reduced to
// a = min/max in [0, 1], then to |r| <= tan(pi/8) with atan(a) = pi/4 +
// atan((a - 1) / (a + 1)); the Taylor series to r^17 leaves < 3e-9 rad.
float Atan2(float y, float x) {
  const float ax = std::abs(x), ay = std::abs(y);
  const float hi = std::max(ax, ay), lo = std::min(ax, ay);
  if (!(hi > 0.0f)) return 0.0f;
  const float a = lo / hi;
  const bool reduced = a > 0.41421356f;
  const float r = reduced ? (a - 1.0f) / (a + 1.0f) : a;
  const float r2 = r * r;
  float p = 1.0f / 17.0f;
  for (float c : {-1.0f / 15.0f, 1.0f / 13.0f, -1.0f / 11.0f, 1.0f / 9.0f, -1.0f / 7.0f, 1.0f / 5.0f, -1.0f / 3.0f,
                  1.0f}) {
    p = p * r2 + c;
  }
  float angle = (reduced ? 0.25f * kPi : 0.0f) + r * p;
  if (ay > ax) angle = 0.5f * kPi - angle;
  if (x < 0.0f) angle = kPi - angle;
  return y < 0.0f ? -angle : angle;
}

// Azimuth in [0, 2 pi) and elevation in [-pi/2, pi/2] (radians); the
// elevation from atan2 so it is accurate near the poles, the azimuth 0 on
// the Y axis. Mirrored by impostorBlendAngles in the shader.
glm::vec2 BlendAngles(glm::vec3 d) {
  const float horizontal = std::sqrt(d.x * d.x + d.z * d.z);
  float az = horizontal > 0.0f ? Atan2(d.x, d.z) : 0.0f;
  if (az < 0.0f) az += kTwoPi;
  if (az >= kTwoPi) az = 0.0f;
  return {az, Atan2(d.y, horizontal)};
}

// Bracketing columns of a ring of `count` frames: c0, c1 = c0 + 1 (wrapping)
// and the fraction toward c1.
struct AzimuthCell {
  int c0, c1;
  float fx;
};
AzimuthCell AzimuthBracket(float az, int count) {
  const float u = az * static_cast<float>(count) / kTwoPi;
  const int c0 = std::clamp(static_cast<int>(std::floor(u)), 0, count - 1);
  return {c0, (c0 + 1) % count, std::clamp(u - static_cast<float>(c0), 0.0f, 1.0f)};
}

FrameBlend BlendAzimuthElevation(const ViewLayout& layout, glm::vec3 d, BlendMode mode) {
  const int n = layout.frames;
  const glm::vec2 ae = BlendAngles(d);
  const AzimuthCell col = AzimuthBracket(ae.x, n);
  const float v = (0.5f * kPi - ae.y) * static_cast<float>(n) / kPi - 0.5f;
  const int r0 = std::clamp(static_cast<int>(std::floor(v)), 0, n - 2);
  const float fx = col.fx;
  const float fy = std::clamp(v - static_cast<float>(r0), 0.0f, 1.0f);
  // Pole caps: beyond the first / last row the pole's frame takes over.
  const float top = std::clamp(-2.0f * v, 0.0f, 1.0f);
  const float bottom = std::clamp(2.0f * (v - static_cast<float>(n - 1)), 0.0f, 1.0f);
  const float cell = 1.0f - top - bottom;
  const int i00 = FrameIndex(n, {col.c0, r0}), i10 = FrameIndex(n, {col.c1, r0});
  const int i01 = FrameIndex(n, {col.c0, r0 + 1}), i11 = FrameIndex(n, {col.c1, r0 + 1});
  FrameBlend blend;
  if (mode == BlendMode::kTriangle3) {
    AddIndex(layout, i00, cell * (1.0f - std::max(fx, fy)), &blend);
    if (fx > fy) AddIndex(layout, i10, cell * (fx - fy), &blend);
    else AddIndex(layout, i01, cell * (fy - fx), &blend);
    AddIndex(layout, i11, cell * std::min(fx, fy), &blend);
  } else {
    AddIndex(layout, i00, cell * (1.0f - fx) * (1.0f - fy), &blend);
    AddIndex(layout, i10, cell * fx * (1.0f - fy), &blend);
    AddIndex(layout, i01, cell * (1.0f - fx) * fy, &blend);
    AddIndex(layout, i11, cell * fx * fy, &blend);
  }
  AddIndex(layout, FrameIndex(n, {0, 0}), top, &blend);
  AddIndex(layout, FrameIndex(n, {0, n - 1}), bottom, &blend);
  return blend;
}

FrameBlend BlendRingTop(const ViewLayout& layout, int ring_views, glm::vec3 d) {
  const glm::vec2 ae = BlendAngles(d);
  const AzimuthCell ring = AzimuthBracket(ae.x, ring_views);
  const float t = std::clamp(ae.y / (0.5f * kPi), 0.0f, 1.0f);
  FrameBlend blend;
  AddIndex(layout, ring.c0, (1.0f - t) * (1.0f - ring.fx), &blend);
  AddIndex(layout, ring.c1, (1.0f - t) * ring.fx, &blend);
  AddIndex(layout, ring_views, t, &blend);
  return blend;
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

ViewLayout ViewLayoutFor(LayoutKind kind, int frames) {
  return ViewLayout{.kind = kind, .frames = frames,
                    .ring_views = kind == LayoutKind::kBillboard ? kBillboardRingViews : 0};
}

FrameBlend BlendFrames(const ViewLayout& layout, glm::vec3 direction, BlendMode mode) {
  const bool ring = layout.kind == LayoutKind::kRingTop || layout.kind == LayoutKind::kBillboard;
  if (!ring && layout.kind != LayoutKind::kAzimuthElevation) {
    return BlendFrames(layout.kind, layout.frames, direction, mode);
  }
  const int ring_views = layout.kind == LayoutKind::kBillboard ? kBillboardRingViews : layout.ring_views;
  if (ring ? ring_views < 1 : layout.frames <= 1) return SingleFrame();
  // As on the octahedral layouts: a zero or non-finite direction is +Y.
  const float length2 = glm::dot(direction, direction);
  if (!(length2 > 0.0f) || !std::isfinite(length2)) direction = glm::vec3(0.0f, 1.0f, 0.0f);
  FrameBlend blend = ring ? BlendRingTop(layout, ring_views, direction)
                          : BlendAzimuthElevation(layout, direction, mode);
  Normalize(&blend);
  return blend;
}

FrameBlend BlendFrames(LayoutKind layout, int frames, glm::vec3 direction, BlendMode mode) {
  if (layout != LayoutKind::kOctahedral && layout != LayoutKind::kHemiOctahedral) {
    return BlendFrames(ViewLayoutFor(layout, frames), direction, mode);
  }
  FrameBlend blend;
  if (frames <= 1) return SingleFrame();
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
