// Depth-aware reconstruction ("depth" mode): every blended frame samples the
// same surface point, and a frame that did not see that point drops out.
//
// "plain" (today's default before depth) samples each blended frame where the
// view ray meets the frame's flat virtual plane; frames 30 degrees apart then
// sample different surface points and the blend shows a double image.
// "depth" uses the depth map every atlas already holds:
//  1. March: for every blended frame i (weight > 0) the view ray is marched
//     through the frame's height field (IntersectFrameHeightField: 16 steps
//     + 4 bisections, as parallax). Frame i's depth map is the front of a
//     solid that contains the object (everything behind what frame i saw),
//     so the ray's entry into it, at distance lambda_i along the ray, is at or
//     before the true surface. A frame whose march finds nothing gives no
//     coverage (the ray misses the object as that frame saw it).
//     That solid is the frame's silhouette extruded backwards, so it also
//     holds points far behind anything the frame saw: a ray passing just
//     above a duck's head as the view sees it enters a lower frame's
//     extrusion behind the head. A hit more than kExtrusionDepth behind the
//     surface its frame saw counts only as far as the other blended frames
//     see that point inside their silhouettes too (a visual hull of the
//     blended frames): by ExtrusionConfirmation of the share of their
//     weight that does, 0 up to half of it, 1 from three quarters. A surface the
//     frame saw edge-on (a box's top from the horizon) passes, a point in
//     empty space behind the object does not.
//  2. Coverage: A = sum_i w_i a_i c_i over the march hits (c_i = 1, or the
//     confirmation of a hit deep in its extrusion); the pixel is covered
//     iff A >= 0.5.
//  3. Candidates: every frame's hit point P_i lies on the ray.
//  4. Agreement (disocclusion): a candidate is projected into every blended
//     frame j (s_j, t_j, height h_j = dot(P - c, d_j) / r) and the frame's
//     surface height S_j there is read. A frame saw P iff S_j = h_j; where it
//     saw something in front of P (P occluded for frame j) or behind it, the
//     difference is large. Its vote is
//     w_j * a_j * g_j, g_j = clamp((kDepthAgreement - |S_j - h_j|) /
//     (kDepthAgreement / 2), 0, 1): 1 up to half the tolerance, 0 beyond.
//     A frame whose march stopped on the wall behind an occluder (a point
//     it never saw) disagrees even with its own hit there.
//     The common point P is the deepest candidate with at least
//     kSupportShare of the best candidate's support: each frame's height
//     field is the front of a solid containing the object, so hits are
//     bounds from the front and the deepest well-seen one is the tightest;
//     a frame with a negligible weight cannot move P on its own.
//  5. Shading: colour, normal, ORM and depth blend the frames' samples at P
//     by their votes w_j * a_j * g_j, so frames that did not see P drop out.
//     If no frame agrees with any candidate (a point no blended frame saw),
//     each frame is sampled at its own hit, as parallax does.
// On a frame's own direction only that frame has weight, P is its march hit
// and the result is the frame itself, as with plain and parallax.
//
// Cost in texture reads per pixel, n = blended frames (3, or 4 for
// bilinear4): per frame the march reads alpha + depth up to 17 + 3c + 4 times
// (c silhouette crossings, virtual_plane.h),
// and a hit deep in its extrusion alpha in the n - 1 other frames;
// the votes read alpha + depth at n candidates in n - 1 other frames; the
// final sample at P reads albedo, normal_depth and ORM once per frame.
#ifndef IMPOSTOR_COMMON_RUNTIME_DEPTH_RECONSTRUCTION_H_
#define IMPOSTOR_COMMON_RUNTIME_DEPTH_RECONSTRUCTION_H_

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <string_view>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "absl/status/statusor.h"
#include "common/atlas/frame_camera.h"
#include "common/runtime/virtual_plane.h"

namespace impostor {

// How a runtime reconstructs a pixel from its blended frames.
enum class Reconstruction {
  kPlain,  // flat virtual planes (with the `parallax` option: marched, no agreement)
  kDepth,  // the common surface point with disocclusion weights (this file)
};

// "plain" / "depth"; anything else is InvalidArgument naming the field.
absl::StatusOr<Reconstruction> ParseReconstruction(std::string_view name);
std::string_view ReconstructionName(Reconstruction mode);

// Tolerance of the agreement test, in radius units (a frame's height
// difference above which it did not see the point). About two bisection
// intervals of the march (2 / 16 / 16 = 0.0078) plus a few texels of a
// 128..256 px tile (2 / tile per texel) on sloped surfaces.
inline constexpr float kDepthAgreement = 0.05f;
// A candidate needs this share of the best candidate's support to be P.
inline constexpr float kSupportShare = 0.5f;
// A march hit this far (radius units) behind the surface its frame saw is in
// the frame's extrusion and needs the other frames' confirmation (step 1):
// twice the agreement tolerance. Measured on the issue-17 assets (hemi-oct
// 12x12, 2048 px) against no confirmation: Duck's pop 4.82 -> 1.70,
// DamagedHelmet's IoU 0.978 -> 0.986, StylizedTree's 0.899 -> 0.942.
inline constexpr float kExtrusionDepth = 2.0f * kDepthAgreement;
// Such a hit counts by the share s of the other frames' weight that sees
// it inside their silhouettes: c = ExtrusionConfirmation(s), fully from
// kExtrusionConfirm of it (the rule up to baker 0.2.0-bake4, which counted
// nothing below), and in proportion from kExtrusionConfirm -
// kExtrusionConfirmRamp. The hard threshold flipped every pixel of a band
// at the same orbit step, as the weights, the same over an orthographic
// view, passed it; with the ramp the share, which varies from pixel to
// pixel, spreads the flips over the steps. A ramp that also lowered hits
// confirmed by more than kExtrusionConfirm (0.5..1) made octahedral
// plants and the Duck pop more (Duck 1.73 -> 2.91). Measured on the
// quality table: docs/quality.md.
inline constexpr float kExtrusionConfirm = 0.75f;
inline constexpr float kExtrusionConfirmRamp = 0.25f;
inline float ExtrusionConfirmation(float share) {
  return std::clamp((share - (kExtrusionConfirm - kExtrusionConfirmRamp)) / kExtrusionConfirmRamp, 0.0f, 1.0f);
}

// The agreement weight g of step 4 for a frame whose surface height at P's
// projection is `surface_height` while P's own height in it is `point_height`.
inline float DepthAgreement(float surface_height, float point_height) {
  const float diff = std::abs(surface_height - point_height);
  return std::clamp((kDepthAgreement - diff) / (0.5f * kDepthAgreement), 0.0f, 1.0f);
}

// The point (radius units from the centre) of a frame sample: st on the
// frame's plane, shifted by its height along the frame direction.
inline glm::vec3 FramePoint(const FrameCamera& frame, const PlaneSample& sample) {
  return sample.st.x * frame.right + sample.st.y * frame.up + sample.height * frame.direction;
}

// P's frame coordinates and height in `frame` (always valid).
inline PlaneSample ProjectPointToFrame(const FrameCamera& frame, glm::vec3 point) {
  PlaneSample out;
  out.valid = true;
  out.st = {glm::dot(point, frame.right), glm::dot(point, frame.up)};
  out.height = glm::dot(point, frame.direction);
  return out;
}

// Distance along the unit ray `ray_unit` from `origin` to a point on it.
inline float RayDistance(glm::vec3 origin, glm::vec3 ray_unit, glm::vec3 point) {
  return glm::dot(point - origin, ray_unit);
}

// Depth mode for one ray over the blended frames (at most 4 entries).
struct DepthEntry {
  const FrameCamera* frame = nullptr;  // the entry's bake camera
  float weight = 0.0f;                 // its blend weight
};
struct DepthSampleAt {
  bool used = false;     // the entry shades the pixel (weight > 0)
  glm::vec2 st{0.0f};    // where to sample it: P's frame coordinates
  float weight = 0.0f;   // w * a * g, not normalised
};
struct DepthPixel {
  float coverage = 0.0f;  // sum of w * a over the march hits; covered iff >= 0.5
  std::array<DepthSampleAt, 4> samples;
};
// The entry's march (IntersectFrameHeightField with its reader).
using DepthMarch = std::function<PlaneSample(int entry)>;
// The entry's filtered coverage at st and, where it is > 0, the surface
// height there (1 - 2 * depth01).
using DepthSurface = std::function<float(int entry, glm::vec2 st, float* height)>;

namespace depth_internal {

// The share of the weight of the blended frames other than `own` that sees
// `point` inside their silhouettes (by filtered coverage); 1 when there is
// no other frame.
template <typename Surface>
float OthersInsideShare(const std::array<DepthEntry, 4>& entries, int count, int own, glm::vec3 point,
                        const Surface& surface) {
  float others = 0.0f;
  float inside = 0.0f;
  for (int j = 0; j < count; ++j) {
    if (j == own || !(entries[j].weight > 0.0f)) continue;
    others += entries[j].weight;
    float height = 0.0f;
    inside += entries[j].weight * surface(j, ProjectPointToFrame(*entries[j].frame, point).st, &height);
  }
  return others > 0.0f ? inside / others : 1.0f;
}

}  // namespace depth_internal

// How many points a batch surface reader (ReconstructDepthBatched) gets at
// once: the other candidates, at most 3.
inline constexpr int kMaxSurfaceBatch = 4;

// `march` and `surface` are any callables of DepthMarch's and DepthSurface's
// signatures (a template, so the reference renderer's lambdas inline).
// `surface_batch(entry, n, st, alpha, height)` reads entry's surface at
// st[0..n) (n <= kMaxSurfaceBatch) as n calls of `surface` would: a reader
// that evaluates several points at once (the reference renderer's, in SIMD
// lanes) takes the agreement test's reads of one frame in one call.
template <typename March, typename Surface, typename SurfaceBatch>
DepthPixel ReconstructDepthBatched(const std::array<DepthEntry, 4>& entries, int count, glm::vec3 origin,
                                   glm::vec3 ray_unit, const March& march, const Surface& surface,
                                   const SurfaceBatch& surface_batch) {
  DepthPixel out;
  count = std::clamp(count, 0, 4);
  std::array<PlaneSample, 4> hits;
  std::array<float, 4> hit_alpha{};
  std::array<float, 4> hit_height{};
  std::array<float, 4> lambda{};
  std::array<glm::vec3, 4> points{};
  for (int i = 0; i < count; ++i) {
    if (!(entries[i].weight > 0.0f)) continue;
    hits[i] = march(i);
    if (!hits[i].valid) continue;
    hit_alpha[i] = surface(i, hits[i].st, &hit_height[i]);
    if (!(hit_alpha[i] > 0.0f)) {
      hits[i].valid = false;
      continue;
    }
    points[i] = FramePoint(*entries[i].frame, hits[i]);
    const float confirmed =
        hit_height[i] - hits[i].height > kExtrusionDepth
            ? ExtrusionConfirmation(depth_internal::OthersInsideShare(entries, count, i, points[i], surface))
            : 1.0f;
    if (!(confirmed > 0.0f)) {
      hits[i].valid = false;
      continue;
    }
    out.coverage += entries[i].weight * hit_alpha[i] * confirmed;
    lambda[i] = RayDistance(origin, ray_unit, points[i]);
  }
  if (out.coverage < 0.5f) return out;
  // Every hit is a candidate for P; each frame votes for it by w * a * g.
  // A frame samples its own hit as it is (no reprojection rounding): that
  // read is the march's hit read above. Each frame's reads of the other
  // candidates go to surface_batch together.
  std::array<std::array<DepthSampleAt, 4>, 4> votes;
  std::array<float, 4> support{};
  for (int j = 0; j < count; ++j) {
    if (!(entries[j].weight > 0.0f)) continue;
    std::array<int, kMaxSurfaceBatch> others{};
    std::array<PlaneSample, kMaxSurfaceBatch> at;
    std::array<glm::vec2, kMaxSurfaceBatch> st{};
    int n = 0;
    for (int c = 0; c < count; ++c) {
      if (!hits[c].valid || c == j) continue;
      others[n] = c;
      at[n] = ProjectPointToFrame(*entries[j].frame, points[c]);
      st[n] = at[n].st;
      ++n;
    }
    std::array<float, kMaxSurfaceBatch> alpha{}, height{};
    if (n > 0) surface_batch(j, n, st.data(), alpha.data(), height.data());
    // Candidates in order, this frame's own (when it is one) in its place.
    int next = 0;
    for (int c = 0; c < count; ++c) {
      if (!hits[c].valid) continue;
      const bool own = c == j;
      const PlaneSample& p = own ? hits[j] : at[next];
      const float a = own ? hit_alpha[j] : alpha[next];
      const float h = own ? hit_height[j] : height[next];
      if (!own) ++next;
      DepthSampleAt& v = votes[c][j];
      v.st = p.st;
      if (!(a > 0.0f)) continue;
      v.weight = entries[j].weight * a * DepthAgreement(h, p.height);
      v.used = v.weight > 0.0f;
      support[c] += v.weight;
    }
  }
  float most = 0.0f;
  for (int c = 0; c < count; ++c) {
    if (hits[c].valid) most = std::max(most, support[c]);
  }
  // The deepest candidate with at least kSupportShare of the most support.
  int best = -1;
  for (int c = 0; c < count; ++c) {
    if (!hits[c].valid || !(support[c] >= kSupportShare * most)) continue;
    if (best < 0 || lambda[c] > lambda[best]) best = c;
  }
  const float best_support = best >= 0 ? support[best] : 0.0f;
  if (best >= 0 && best_support > 0.0f) {
    out.samples = votes[best];
    return out;
  }
  // No frame saw any candidate: each frame at its own hit (parallax).
  for (int j = 0; j < count; ++j) {
    if (!hits[j].valid) continue;
    out.samples[j] = {true, hits[j].st, entries[j].weight * hit_alpha[j]};
  }
  return out;
}

// ReconstructDepthBatched with the agreement test's reads one at a time.
template <typename March, typename Surface>
DepthPixel ReconstructDepth(const std::array<DepthEntry, 4>& entries, int count, glm::vec3 origin,
                            glm::vec3 ray_unit, const March& march, const Surface& surface) {
  return ReconstructDepthBatched(entries, count, origin, ray_unit, march, surface,
                                 [&](int entry, int n, const glm::vec2* st, float* alpha, float* height) {
                                   for (int k = 0; k < n; ++k) alpha[k] = surface(entry, st[k], &height[k]);
                                 });
}

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_RUNTIME_DEPTH_RECONSTRUCTION_H_
