#include "worker/surfels/voxel_binning.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <utility>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

namespace impostor {
namespace {

// Spreads the low 21 bits of v so that there are two zero bits between each.
uint64_t Spread3(uint64_t v) {
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffffULL;
  v = (v | v << 16) & 0x1f0000ff0000ffULL;
  v = (v | v << 8) & 0x100f00f00f00f00fULL;
  v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
  v = (v | v << 2) & 0x1249249249249249ULL;
  return v;
}

uint64_t CellKey(const glm::vec3& p, const VoxelGrid& grid, float inv_size) {
  uint64_t key = 0;
  for (int a = 0; a < 3; ++a) {
    const float f = std::floor((p[a] - grid.origin[a]) * inv_size);
    const int64_t c = std::clamp<int64_t>(static_cast<int64_t>(f), 0, kMaxCellsPerAxis - 1);
    key |= Spread3(static_cast<uint64_t>(c)) << a;
  }
  return key;
}

}  // namespace

SampleBounds BoundsOf(const std::vector<Surfel>& samples) {
  SampleBounds b;
  if (samples.empty()) return b;
  b.min = b.max = samples.front().position;
  for (const Surfel& s : samples) {
    b.min = glm::min(b.min, s.position);
    b.max = glm::max(b.max, s.position);
  }
  return b;
}

float MinVoxelSizeFor(const SampleBounds& bounds) {
  const glm::vec3 e = bounds.max - bounds.min;
  const float extent = std::max({e.x, e.y, e.z});
  // One cell of slack so that the largest coordinate never reaches the limit.
  return std::max(extent / (kMaxCellsPerAxis - 2), 1e-30f);
}

size_t CountOccupiedCells(const std::vector<Surfel>& samples, const VoxelGrid& grid) {
  const float inv = 1.0f / grid.voxel_size;
  std::vector<uint64_t> keys;
  keys.reserve(samples.size());
  for (const Surfel& s : samples) keys.push_back(CellKey(s.position, grid, inv));
  std::sort(keys.begin(), keys.end());
  return static_cast<size_t>(std::unique(keys.begin(), keys.end()) - keys.begin());
}

std::vector<Surfel> BinSamples(const std::vector<Surfel>& samples, const VoxelGrid& grid) {
  const float inv = 1.0f / grid.voxel_size;
  // (cell, sample index): sorting keeps each cell's samples in input order,
  // so "the cell's first sample" is well defined and the output is
  // deterministic.
  std::vector<std::pair<uint64_t, uint32_t>> order;
  order.reserve(samples.size());
  for (size_t i = 0; i < samples.size(); ++i) {
    order.emplace_back(CellKey(samples[i].position, grid, inv), static_cast<uint32_t>(i));
  }
  std::sort(order.begin(), order.end());
  std::vector<Surfel> points;
  for (size_t begin = 0; begin < order.size();) {
    size_t end = begin;
    glm::dvec3 position(0.0), albedo(0.0), orm(0.0);
    glm::vec3 normal(0.0f);
    const glm::vec3 reference = samples[order[begin].second].normal;
    for (; end < order.size() && order[end].first == order[begin].first; ++end) {
      const Surfel& s = samples[order[end].second];
      position += glm::dvec3(s.position);
      albedo += glm::dvec3(s.albedo);
      orm += glm::dvec3(s.orm);
      normal += glm::dot(s.normal, reference) < 0.0f ? -s.normal : s.normal;
    }
    const double n = static_cast<double>(end - begin);
    Surfel p;
    p.position = glm::vec3(position / n);
    p.albedo = glm::vec3(albedo / n);
    p.orm = glm::vec3(orm / n);
    // Every term has a non-negative dot with the unit reference, which is
    // itself a term, so the sum has length >= 1.
    p.normal = glm::normalize(normal);
    points.push_back(p);
    begin = end;
  }
  return points;
}

BudgetFit FitVoxelSizeToBudget(const std::vector<Surfel>& samples, size_t budget, float min_voxel_size,
                               double tolerance, int max_evaluations) {
  assert(budget >= 1 && min_voxel_size > 0.0f && !samples.empty());
  const SampleBounds bounds = BoundsOf(samples);
  const glm::vec3 e = bounds.max - bounds.min;
  BudgetFit fit;
  auto count = [&](float size) {
    ++fit.evaluations;
    return CountOccupiedCells(samples, VoxelGrid{bounds.min, size});
  };
  // A cell larger than the whole extent holds every sample: one point.
  float hi = std::max({e.x, e.y, e.z}) * 1.001f + min_voxel_size;
  float lo = std::max(min_voxel_size, MinVoxelSizeFor(bounds));
  if (lo >= hi) lo = hi;
  const size_t at_lo = count(lo);
  if (at_lo <= budget) {
    fit.voxel_size = lo;
    fit.point_count = at_lo;
    fit.budget_reached = at_lo == budget;
    return fit;
  }
  fit.voxel_size = hi;
  fit.point_count = 1;
  // Invariant: count(lo) > budget >= count(hi).
  while (fit.evaluations < max_evaluations && hi / lo > 1.0f + 1e-6f) {
    const float mid = std::sqrt(lo * hi);
    const size_t n = count(mid);
    if (n <= budget) {
      hi = mid;
      if (n > fit.point_count) {
        fit.point_count = n;
        fit.voxel_size = mid;
      }
      if (static_cast<double>(budget - n) <= tolerance * static_cast<double>(budget)) break;
    } else {
      lo = mid;
    }
  }
  return fit;
}

}  // namespace impostor
