#include "worker/scene/tangent_space.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>

namespace impostor::gltf_internal {

glm::vec3 AnyOrthogonal(glm::vec3 n) {
  // Cross with the axis least aligned with n: never degenerate.
  const glm::vec3 a = std::abs(n.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
  return glm::normalize(glm::cross(a, n));
}

std::vector<glm::vec3> ComputeSmoothNormals(std::span<const glm::vec3> positions,
                                            std::span<const uint32_t> triangles) {
  std::vector<glm::vec3> sum(positions.size(), glm::vec3(0.0f));
  for (size_t t = 0; t + 2 < triangles.size(); t += 3) {
    const uint32_t i0 = triangles[t], i1 = triangles[t + 1], i2 = triangles[t + 2];
    const glm::vec3 face = glm::cross(positions[i1] - positions[i0], positions[i2] - positions[i0]);
    sum[i0] += face;
    sum[i1] += face;
    sum[i2] += face;
  }
  for (glm::vec3& n : sum) {
    const float len = glm::length(n);
    n = (len > 0.0f && std::isfinite(len)) ? n / len : glm::vec3(0, 1, 0);
  }
  return sum;
}

std::vector<glm::vec4> ComputeTangents(std::span<const glm::vec3> positions,
                                       std::span<const glm::vec3> normals,
                                       std::span<const glm::vec2> uvs,
                                       std::span<const uint32_t> triangles) {
  std::vector<glm::vec3> tan(positions.size(), glm::vec3(0.0f));
  std::vector<glm::vec3> bitan(positions.size(), glm::vec3(0.0f));
  for (size_t t = 0; t + 2 < triangles.size(); t += 3) {
    const uint32_t idx[3] = {triangles[t], triangles[t + 1], triangles[t + 2]};
    const glm::vec3 e1 = positions[idx[1]] - positions[idx[0]];
    const glm::vec3 e2 = positions[idx[2]] - positions[idx[0]];
    const glm::vec2 d1 = uvs[idx[1]] - uvs[idx[0]];
    const glm::vec2 d2 = uvs[idx[2]] - uvs[idx[0]];
    const float det = d1.x * d2.y - d2.x * d1.y;
    if (det == 0.0f || !std::isfinite(det)) continue;
    // Solving [e1 e2] = [T B] [d1 d2] for T, B (up to the positive factor
    // |det|, which the normalisation below removes).
    const float sign = det > 0.0f ? 1.0f : -1.0f;
    const glm::vec3 t_dir = (e1 * d2.y - e2 * d1.y) * sign;
    const glm::vec3 b_dir = (e2 * d1.x - e1 * d2.x) * sign;
    for (int c = 0; c < 3; ++c) {
      const uint32_t i = idx[c];
      const glm::vec3 n = normals[i];
      // As MikkTSpace: the face tangent is projected into the vertex's
      // tangent plane and normalised, then weighted by the corner angle, so
      // a vertex's tangent does not depend on how finely the surface around
      // it is split into triangles.
      glm::vec3 tp = t_dir - n * glm::dot(n, t_dir);
      glm::vec3 bp = b_dir - n * glm::dot(n, b_dir);
      const float tl = glm::length(tp), bl = glm::length(bp);
      const glm::vec3 a = positions[idx[(c + 1) % 3]] - positions[i];
      const glm::vec3 b = positions[idx[(c + 2) % 3]] - positions[i];
      const float al = glm::length(a), blen = glm::length(b);
      if (!(al > 0.0f) || !(blen > 0.0f)) continue;
      const float angle = std::acos(std::clamp(glm::dot(a, b) / (al * blen), -1.0f, 1.0f));
      if (tl > 0.0f && std::isfinite(tl)) tan[i] += tp / tl * angle;
      if (bl > 0.0f && std::isfinite(bl)) bitan[i] += bp / bl * angle;
    }
  }
  std::vector<glm::vec4> out(positions.size());
  for (size_t i = 0; i < positions.size(); ++i) {
    const glm::vec3 n = normals[i];
    glm::vec3 t = tan[i] - n * glm::dot(n, tan[i]);  // Gram-Schmidt
    const float len = glm::length(t);
    if (!(len > 1e-20f) || !std::isfinite(len)) {
      out[i] = glm::vec4(AnyOrthogonal(n), 1.0f);
      continue;
    }
    t /= len;
    const float w = glm::dot(glm::cross(n, t), bitan[i]) < 0.0f ? -1.0f : 1.0f;
    out[i] = glm::vec4(t, w);
  }
  return out;
}

}  // namespace impostor::gltf_internal
