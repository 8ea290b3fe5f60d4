#include "common/runtime/depth_reconstruction.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <glm/geometric.hpp>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace impostor {

absl::StatusOr<Reconstruction> ParseReconstruction(std::string_view name) {
  if (name == "plain") return Reconstruction::kPlain;
  if (name == "depth") return Reconstruction::kDepth;
  return absl::InvalidArgumentError(
      absl::StrCat("reconstruction: '", std::string(name), "' is not one of plain, depth"));
}

std::string_view ReconstructionName(Reconstruction mode) {
  return mode == Reconstruction::kDepth ? "depth" : "plain";
}

float DepthAgreement(float surface_height, float point_height) {
  const float diff = std::abs(surface_height - point_height);
  return std::clamp((kDepthAgreement - diff) / (0.5f * kDepthAgreement), 0.0f, 1.0f);
}

glm::vec3 FramePoint(const FrameCamera& frame, const PlaneSample& sample) {
  return sample.st.x * frame.right + sample.st.y * frame.up + sample.height * frame.direction;
}

PlaneSample ProjectPointToFrame(const FrameCamera& frame, glm::vec3 point) {
  PlaneSample out;
  out.valid = true;
  out.st = {glm::dot(point, frame.right), glm::dot(point, frame.up)};
  out.height = glm::dot(point, frame.direction);
  return out;
}

float RayDistance(glm::vec3 origin, glm::vec3 ray_unit, glm::vec3 point) {
  return glm::dot(point - origin, ray_unit);
}

namespace {

// Whether the blended frames other than `own` see `point` inside their
// silhouettes (kExtrusionConfirm of their weight, by filtered coverage).
bool OthersSeeInside(const std::array<DepthEntry, 4>& entries, int count, int own, glm::vec3 point,
                     const DepthSurface& surface) {
  float others = 0.0f;
  float inside = 0.0f;
  for (int j = 0; j < count; ++j) {
    if (j == own || !(entries[j].weight > 0.0f)) continue;
    others += entries[j].weight;
    float height = 0.0f;
    inside += entries[j].weight * surface(j, ProjectPointToFrame(*entries[j].frame, point).st, &height);
  }
  return !(others > 0.0f) || inside >= kExtrusionConfirm * others;
}

}  // namespace

DepthPixel ReconstructDepth(const std::array<DepthEntry, 4>& entries, int count, glm::vec3 origin,
                            glm::vec3 ray_unit, const DepthMarch& march, const DepthSurface& surface) {
  DepthPixel out;
  count = std::clamp(count, 0, 4);
  std::array<PlaneSample, 4> hits;
  std::array<float, 4> hit_alpha{};
  std::array<float, 4> lambda{};
  for (int i = 0; i < count; ++i) {
    if (!(entries[i].weight > 0.0f)) continue;
    hits[i] = march(i);
    if (!hits[i].valid) continue;
    float height = 0.0f;
    hit_alpha[i] = surface(i, hits[i].st, &height);
    if (!(hit_alpha[i] > 0.0f)) {
      hits[i].valid = false;
      continue;
    }
    const glm::vec3 point = FramePoint(*entries[i].frame, hits[i]);
    if (height - hits[i].height > kExtrusionDepth && !OthersSeeInside(entries, count, i, point, surface)) {
      hits[i].valid = false;
      continue;
    }
    out.coverage += entries[i].weight * hit_alpha[i];
    lambda[i] = RayDistance(origin, ray_unit, point);
  }
  if (out.coverage < 0.5f) return out;
  // Every hit is a candidate for P; each frame votes for it by w * a * g.
  std::array<std::array<DepthSampleAt, 4>, 4> votes;
  std::array<float, 4> support{};
  float most = 0.0f;
  for (int c = 0; c < count; ++c) {
    if (!hits[c].valid) continue;
    const glm::vec3 point = FramePoint(*entries[c].frame, hits[c]);
    for (int j = 0; j < count; ++j) {
      if (!(entries[j].weight > 0.0f)) continue;
      // A frame samples its own hit as it is (no reprojection rounding).
      const PlaneSample at = j == c ? hits[j] : ProjectPointToFrame(*entries[j].frame, point);
      float height = 0.0f;
      const float alpha = surface(j, at.st, &height);
      DepthSampleAt& v = votes[c][j];
      v.st = at.st;
      if (!(alpha > 0.0f)) continue;
      v.weight = entries[j].weight * alpha * DepthAgreement(height, at.height);
      v.used = v.weight > 0.0f;
      support[c] += v.weight;
    }
    most = std::max(most, support[c]);
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

}  // namespace impostor
