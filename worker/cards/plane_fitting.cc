// Billboard-cloud plane fitting after Décoret, Durand, Sillion & Dorsey,
// "Billboard Clouds for Extreme Model Simplification", SIGGRAPH 2003.
// See plane_fitting.h for what is kept from the paper and what differs.
#include "worker/cards/plane_fitting.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <queue>
#include <utility>

#include <glm/geometric.hpp>

namespace impostor {
namespace {

// Triangle-normal votes the automatic lattice size aims for.
constexpr double kVoteBudget = 5e7;
constexpr int kMinNormals = 64;
constexpr int kMaxNormals = 4096;
// Normals of this many of the largest triangles join the lattice.
constexpr size_t kTriangleNormalCandidates = 512;

// One representative of n and -n (a plane and its flip are one plane).
glm::vec3 Canonical(glm::vec3 n) {
  if (n.y < 0.0f || (n.y == 0.0f && (n.z < 0.0f || (n.z == 0.0f && n.x < 0.0f)))) return -n;
  return n;
}

std::vector<glm::vec3> FibonacciHemisphere(int count) {
  std::vector<glm::vec3> out;
  out.reserve(static_cast<size_t>(count));
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < count; ++i) {
    const double y = (i + 0.5) / count;
    const double r = std::sqrt(std::max(0.0, 1.0 - y * y));
    const double phi = golden * i;
    out.push_back(glm::vec3(static_cast<float>(r * std::cos(phi)), static_cast<float>(y),
                            static_cast<float>(r * std::sin(phi))));
  }
  return out;
}

glm::vec3 FaceNormal(const Triangle3& t) { return glm::cross(t[1] - t[0], t[2] - t[0]); }

// Best offset delta (plane dot(n, p) = delta) for `n` over the triangles
// still unassigned, and the area it holds within `eps`.
struct Scored {
  double score = 0;
  float offset = 0;
};

// Offsets are scored on a fixed grid of bins eps / 4 wide spanning the
// mesh's extent about its box centre (the same grid every round, so a
// normal's score never rises as triangles are taken: the lazy greedy's
// bounds stay valid). A triangle counts for the bins lying wholly inside its
// interval of valid offsets, so any offset in the best bin holds every
// triangle counted; O(triangles + bins) per normal. Grids finer than this
// many bins (tiny tolerances) fall back to sorting interval end points.
constexpr int64_t kMaxOffsetBins = 16384;

struct OffsetGrid {
  glm::vec3 center{0.0f};
  double extent = 0;
};

Scored BestOffset(const glm::vec3& n, std::span<const Triangle3> tris, const std::vector<uint32_t>& remaining,
                  const std::vector<double>& weight, float eps, const OffsetGrid& grid,
                  std::vector<std::pair<float, double>>& events, std::vector<double>& bins) {
  const double width = eps / 4.0;
  const double origin = glm::dot(n, grid.center) - grid.extent;
  const auto bin_count = static_cast<int64_t>(std::ceil(2.0 * grid.extent / width)) + 2;
  Scored best;
  if (bin_count <= kMaxOffsetBins) {
    bins.assign(static_cast<size_t>(bin_count) + 1, 0.0);
    for (uint32_t i : remaining) {
      const Triangle3& t = tris[i];
      const float a = glm::dot(n, t[0]), b = glm::dot(n, t[1]), c = glm::dot(n, t[2]);
      const double lo = std::max({a, b, c}) - eps, hi = std::min({a, b, c}) + eps;
      if (lo > hi) continue;
      const auto first = std::max<int64_t>(0, static_cast<int64_t>(std::ceil((lo - origin) / width)));
      const auto last = std::min<int64_t>(bin_count - 1, static_cast<int64_t>(std::floor((hi - origin) / width)) - 1);
      if (first > last) continue;
      bins[first] += weight[i];
      bins[last + 1] -= weight[i];
    }
    double running = 0;
    for (int64_t k = 0; k < bin_count; ++k) {
      running += bins[k];
      if (running > best.score * (1.0 + 1e-12)) {
        best.score = running;
        best.offset = static_cast<float>(origin + (k + 0.5) * width);
      }
    }
    return best;
  }
  events.clear();
  for (uint32_t i : remaining) {
    const Triangle3& t = tris[i];
    const float a = glm::dot(n, t[0]), b = glm::dot(n, t[1]), c = glm::dot(n, t[2]);
    const float lo = std::max({a, b, c}) - eps, hi = std::min({a, b, c}) + eps;
    if (lo > hi) continue;
    events.emplace_back(lo, weight[i]);
    events.emplace_back(hi, -weight[i]);
  }
  // Openings before closings at one position: touching intervals overlap.
  std::sort(events.begin(), events.end(), [](const auto& x, const auto& y) {
    return x.first < y.first || (x.first == y.first && x.second > y.second);
  });
  double running = 0;
  for (size_t k = 0; k < events.size(); ++k) {
    running += events[k].second;
    if (running > best.score) {
      best.score = running;
      const float next = k + 1 < events.size() ? events[k + 1].first : events[k].first;
      best.offset = 0.5f * (events[k].first + next);
    }
  }
  return best;
}

// Eigenvector of the smallest eigenvalue of a symmetric 3x3 matrix (cyclic
// Jacobi; converges in a few sweeps at this size).
glm::dvec3 SmallestEigenvector(double a[3][3]) {
  double v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int sweep = 0; sweep < 32; ++sweep) {
    const double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
    if (off < 1e-30) break;
    for (int p = 0; p < 2; ++p) {
      for (int q = p + 1; q < 3; ++q) {
        if (std::abs(a[p][q]) < 1e-300) continue;
        const double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
        const double t = (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1.0));
        const double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c;
        for (int k = 0; k < 3; ++k) {  // A = J^T A J
          const double akp = a[k][p], akq = a[k][q];
          a[k][p] = c * akp - s * akq;
          a[k][q] = s * akp + c * akq;
        }
        for (int k = 0; k < 3; ++k) {
          const double apk = a[p][k], aqk = a[q][k];
          a[p][k] = c * apk - s * aqk;
          a[q][k] = s * apk + c * aqk;
        }
        for (int k = 0; k < 3; ++k) {
          const double vkp = v[k][p], vkq = v[k][q];
          v[k][p] = c * vkp - s * vkq;
          v[k][q] = s * vkp + c * vkq;
        }
      }
    }
  }
  int m = 0;
  for (int i = 1; i < 3; ++i) {
    if (a[i][i] < a[m][m]) m = i;
  }
  return {v[0][m], v[1][m], v[2][m]};
}

// Area-weighted least-squares plane through the triangles' vertices,
// oriented like `hint`. False when the vertices do not span a plane.
bool FitPlaneLeastSquares(std::span<const Triangle3> tris, const std::vector<uint32_t>& members,
                          const std::vector<double>& weight, const glm::vec3& hint, glm::vec3* n, float* delta) {
  double total = 0;
  glm::dvec3 c(0.0);
  for (uint32_t i : members) {
    for (const glm::vec3& p : tris[i]) c += weight[i] * glm::dvec3(p);
    total += 3 * weight[i];
  }
  if (!(total > 0)) return false;
  c /= total;
  double cov[3][3] = {};
  for (uint32_t i : members) {
    for (const glm::vec3& p : tris[i]) {
      const glm::dvec3 d = glm::dvec3(p) - c;
      for (int r = 0; r < 3; ++r) {
        for (int k = 0; k < 3; ++k) cov[r][k] += weight[i] * d[r] * d[k];
      }
    }
  }
  glm::dvec3 e = SmallestEigenvector(cov);
  const double len = glm::length(e);
  if (!(len > 0) || !std::isfinite(len)) return false;
  e /= len;
  if (glm::dot(e, glm::dvec3(hint)) < 0) e = -e;
  *n = glm::vec3(e);
  *delta = static_cast<float>(glm::dot(e, c));
  return true;
}

std::vector<uint32_t> Within(std::span<const Triangle3> tris, const std::vector<uint32_t>& remaining,
                             const glm::vec3& n, float delta, float eps) {
  std::vector<uint32_t> out;
  for (uint32_t i : remaining) {
    if (TriangleDistance(tris[i], n, -delta) <= eps) out.push_back(i);
  }
  return out;
}

double WeightOf(const std::vector<uint32_t>& members, const std::vector<double>& weight) {
  double w = 0;
  for (uint32_t i : members) w += weight[i];
  return w;
}

}  // namespace

float TriangleDistance(const Triangle3& t, const glm::vec3& normal, float d) {
  float m = 0.0f;
  for (const glm::vec3& p : t) m = std::max(m, std::abs(glm::dot(normal, p) + d));
  return m;
}

PlaneFit FitPlanes(std::span<const Triangle3> tris, const PlaneFitOptions& options) {
  PlaneFit fit;
  const size_t count = tris.size();
  fit.triangle_plane.assign(count, 0);
  if (count == 0) return fit;
  const float eps = options.tolerance;
  const int max_planes = std::max(1, options.max_planes);

  glm::vec3 lo(std::numeric_limits<float>::max()), hi(std::numeric_limits<float>::lowest());
  for (const Triangle3& t : tris) {
    for (const glm::vec3& p : t) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
  }
  const double extent = std::max(1e-30, 0.5 * glm::length(glm::dvec3(hi - lo)));

  // Area weights; a tiny floor so degenerate triangles still count.
  std::vector<double> weight(count);
  for (size_t i = 0; i < count; ++i) {
    weight[i] = 0.5 * glm::length(glm::dvec3(FaceNormal(tris[i]))) + 1e-9 * extent * extent;
  }

  // Candidate normals.
  int lattice = options.normal_samples;
  if (lattice <= 0) {
    // Angular step ~ tolerance / extent keeps a lattice plane within the
    // tolerance of a planar piece somewhere; the hemisphere is 2 pi sr.
    const double step = std::max(1e-4, static_cast<double>(eps) / extent);
    const double wanted = 2.0 * std::numbers::pi / (step * step);
    const double affordable = kVoteBudget / static_cast<double>(count);
    lattice = static_cast<int>(std::clamp(std::min(wanted, affordable), double{kMinNormals}, double{kMaxNormals}));
  }
  std::vector<glm::vec3> normals = FibonacciHemisphere(lattice);
  {
    std::vector<uint32_t> by_area(count);
    for (size_t i = 0; i < count; ++i) by_area[i] = static_cast<uint32_t>(i);
    const size_t k = std::min(count, kTriangleNormalCandidates);
    std::partial_sort(by_area.begin(), by_area.begin() + static_cast<std::ptrdiff_t>(k), by_area.end(),
                      [&](uint32_t a, uint32_t b) { return weight[a] > weight[b]; });
    for (size_t j = 0; j < k; ++j) {
      const glm::vec3 f = FaceNormal(tris[by_area[j]]);
      if (glm::length(f) > 0.0f) normals.push_back(Canonical(glm::normalize(f)));
    }
  }

  std::vector<uint32_t> remaining(count);
  for (size_t i = 0; i < count; ++i) remaining[i] = static_cast<uint32_t>(i);
  std::vector<int> assigned(count, -1);
  std::vector<std::pair<float, double>> events;
  std::vector<double> bins;
  const OffsetGrid grid{0.5f * (lo + hi), extent * 1.001 + eps};

  // Lazy greedy: (upper bound of the normal's score, candidate index).
  std::priority_queue<std::pair<double, size_t>> heap;
  for (size_t c = 0; c < normals.size(); ++c) heap.emplace(std::numeric_limits<double>::infinity(), c);

  while (!remaining.empty() && static_cast<int>(fit.planes.size()) < max_planes) {
    // The largest unassigned triangle's own plane always holds it.
    uint32_t largest = remaining.front();
    for (uint32_t i : remaining) {
      if (weight[i] > weight[largest]) largest = i;
    }
    glm::vec3 best_n(0.0f, 1.0f, 0.0f);
    Scored best;
    if (const glm::vec3 f = FaceNormal(tris[largest]); glm::length(f) > 0.0f) {
      best_n = Canonical(glm::normalize(f));
      best = BestOffset(best_n, tris, remaining, weight, eps, grid, events, bins);
    }
    while (!heap.empty() && heap.top().first > best.score) {
      const size_t c = heap.top().second;
      heap.pop();
      const Scored s = BestOffset(normals[c], tris, remaining, weight, eps, grid, events, bins);
      heap.emplace(s.score, c);
      if (s.score > best.score) {
        best = s;
        best_n = normals[c];
      }
    }

    std::vector<uint32_t> members = Within(tris, remaining, best_n, best.offset, eps);
    if (members.empty()) {
      // Only for a degenerate largest triangle: take it alone.
      members = {largest};
      best_n = glm::vec3(0.0f, 1.0f, 0.0f);
      best.offset = glm::dot(best_n, tris[largest][0]);
    }
    // Refine to the least-squares plane of what it took while that holds as
    // much area within the tolerance.
    for (int iteration = 0; iteration < 3; ++iteration) {
      glm::vec3 n;
      float delta;
      if (!FitPlaneLeastSquares(tris, members, weight, best_n, &n, &delta)) break;
      std::vector<uint32_t> refined = Within(tris, remaining, n, delta, eps);
      if (WeightOf(refined, weight) < WeightOf(members, weight)) break;
      const bool same = refined == members && n == best_n && delta == best.offset;
      best_n = n;
      best.offset = delta;
      members = std::move(refined);
      if (same) break;
    }

    const auto plane_index = static_cast<uint32_t>(fit.planes.size());
    FittedPlane plane;
    plane.normal = best_n;
    plane.d = -best.offset;
    fit.planes.push_back(plane);
    for (uint32_t i : members) assigned[i] = static_cast<int>(plane_index);
    std::erase_if(remaining, [&](uint32_t i) { return assigned[i] >= 0; });
  }

  if (!remaining.empty()) {
    fit.budget_exhausted = true;
    for (uint32_t i : remaining) {
      float nearest = std::numeric_limits<float>::max();
      for (size_t p = 0; p < fit.planes.size(); ++p) {
        const float dist = TriangleDistance(tris[i], fit.planes[p].normal, fit.planes[p].d);
        if (dist < nearest) {
          nearest = dist;
          assigned[i] = static_cast<int>(p);
        }
      }
    }
  }

  // Face each plane the way most of its triangles face, then measure.
  std::vector<double> facing(fit.planes.size(), 0.0);
  for (size_t i = 0; i < count; ++i) {
    fit.triangle_plane[i] = static_cast<uint32_t>(assigned[i]);
    facing[assigned[i]] += glm::dot(glm::dvec3(FaceNormal(tris[i])), glm::dvec3(fit.planes[assigned[i]].normal));
  }
  for (size_t p = 0; p < fit.planes.size(); ++p) {
    if (facing[p] < 0) {
      fit.planes[p].normal = -fit.planes[p].normal;
      fit.planes[p].d = -fit.planes[p].d;
    }
  }
  std::vector<double> sums(fit.planes.size(), 0.0);
  double total = 0;
  for (size_t i = 0; i < count; ++i) {
    FittedPlane& plane = fit.planes[fit.triangle_plane[i]];
    const float dist = TriangleDistance(tris[i], plane.normal, plane.d);
    plane.triangles++;
    plane.max_distance = std::max(plane.max_distance, dist);
    sums[fit.triangle_plane[i]] += dist;
    fit.max_distance = std::max(fit.max_distance, dist);
    total += dist;
  }
  for (size_t p = 0; p < fit.planes.size(); ++p) {
    if (fit.planes[p].triangles > 0) {
      fit.planes[p].mean_distance = static_cast<float>(sums[p] / fit.planes[p].triangles);
    }
  }
  fit.mean_distance = static_cast<float>(total / static_cast<double>(count));
  return fit;
}

}  // namespace impostor
