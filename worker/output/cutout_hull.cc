#include "worker/output/cutout_hull.h"

#include <algorithm>
#include <cmath>

#include <glm/common.hpp>
#include <glm/vec2.hpp>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

using Point = glm::dvec2;

double Cross(Point o, Point a, Point b) { return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x); }

// Andrew's monotone chain; counter-clockwise in a y-up frame, collinear
// points dropped.
std::vector<Point> ConvexHull(std::vector<Point> p) {
  std::sort(p.begin(), p.end(), [](Point a, Point b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
  p.erase(std::unique(p.begin(), p.end()), p.end());
  if (p.size() < 3) return p;
  std::vector<Point> hull(2 * p.size());
  size_t k = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && Cross(hull[k - 2], hull[k - 1], p[i]) <= 0) --k;
    hull[k++] = p[i];
  }
  for (size_t i = p.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && Cross(hull[k - 2], hull[k - 1], p[i - 1]) <= 0) --k;
    hull[k++] = p[i - 1];
  }
  hull.resize(k - 1);
  return hull;
}

double Area(const std::vector<Point>& poly) {
  double a = 0;
  for (size_t i = 0; i < poly.size(); ++i) {
    const Point& p = poly[i];
    const Point& q = poly[(i + 1) % poly.size()];
    a += p.x * q.y - q.x * p.y;
  }
  return std::abs(a) * 0.5;
}

// Where the lines through (a, b) and (c, d) meet, if they do ahead of b and
// behind c (the edge b-c between them is the one removed).
bool ExtendedMeet(Point a, Point b, Point c, Point d, Point* out) {
  const Point r = b - a, s = c - d;
  const double denom = r.x * s.y - r.y * s.x;
  if (std::abs(denom) < 1e-12) return false;
  const Point ca = d - a;
  const double t = (ca.x * s.y - ca.y * s.x) / denom;
  const double u = (ca.x * r.y - ca.y * r.x) / denom;
  if (t < 1.0 - 1e-9 || u < 1.0 - 1e-9) return false;
  *out = a + t * r;
  return true;
}

// Removes edges until at most `max_vertices` remain; false if it cannot
// without leaving [0, w] x [0, h].
bool Simplify(std::vector<Point>* poly, int max_vertices, double w, double h) {
  constexpr double kEps = 1e-9;
  while (static_cast<int>(poly->size()) > max_vertices) {
    const size_t n = poly->size();
    double best_cost = INFINITY;
    size_t best = n;
    Point best_point;
    for (size_t i = 0; i < n; ++i) {
      const Point& a = (*poly)[(i + n - 1) % n];
      const Point& b = (*poly)[i];
      const Point& c = (*poly)[(i + 1) % n];
      const Point& d = (*poly)[(i + 2) % n];
      Point meet;
      if (!ExtendedMeet(a, b, c, d, &meet)) continue;
      if (meet.x < -kEps || meet.y < -kEps || meet.x > w + kEps || meet.y > h + kEps) continue;
      const double cost = std::abs(Cross(b, meet, c)) * 0.5;
      if (cost < best_cost) {
        best_cost = cost;
        best = i;
        best_point = meet;
      }
    }
    if (best == n) return false;
    // b = poly[best] becomes the meeting point, c is dropped.
    (*poly)[best] = glm::clamp(best_point, Point(0.0), Point(w, h));
    poly->erase(poly->begin() + static_cast<std::ptrdiff_t>((best + 1) % n));
  }
  return true;
}

}  // namespace

CutoutPolygon CutoutFromMask(std::span<const uint8_t> mask, int tile_width, int tile_height, int max_vertices) {
  const double w = tile_width, h = tile_height;
  std::vector<Point> corners;
  for (int y = 0; y < tile_height; ++y) {
    int first = -1, last = -1;
    for (int x = 0; x < tile_width; ++x) {
      if (mask[static_cast<size_t>(y) * tile_width + x] == 0) continue;
      if (first < 0) first = x;
      last = x;
    }
    if (first < 0) continue;
    // The row's extreme texels' outer corners bound every texel of the row.
    corners.push_back({first, y});
    corners.push_back({first, y + 1});
    corners.push_back({last + 1, y});
    corners.push_back({last + 1, y + 1});
  }
  std::vector<Point> hull = ConvexHull(std::move(corners));
  if (hull.size() < 3 || !Simplify(&hull, max_vertices, w, h)) {
    hull = {{0, 0}, {w, 0}, {w, h}, {0, h}};
  }
  // Monotone chain is counter-clockwise with y up, i.e. clockwise as the
  // image is displayed (y down): reverse for the documented order.
  std::reverse(hull.begin(), hull.end());
  CutoutPolygon out;
  for (const Point& p : hull) {
    out.vertices.push_back({static_cast<float>(p.x / w), static_cast<float>(p.y / h)});
  }
  out.area_ratio = static_cast<float>(std::min(1.0, Area(hull) / (w * h)));
  return out;
}

absl::StatusOr<CutoutPolygon> ComputeCutout(std::span<const uint8_t> rgba, int width, int height,
                                            std::span<const TileRect> tiles, int max_vertices) {
  if (width <= 0 || height <= 0 || rgba.size() != static_cast<size_t>(width) * height * 4) {
    return absl::InvalidArgumentError(absl::StrCat("cutout: image buffer of ", rgba.size(), " bytes for ",
                                                   width, "x", height, " RGBA8"));
  }
  if (max_vertices < 4) {
    return absl::InvalidArgumentError(absl::StrCat("cutout: max_vertices ", max_vertices, " is below 4"));
  }
  if (tiles.empty()) return absl::InvalidArgumentError("cutout: no tiles");
  const int tw = tiles[0].width, th = tiles[0].height;
  std::vector<uint8_t> mask(static_cast<size_t>(tw) * th, 0);
  for (const TileRect& t : tiles) {
    if (t.width != tw || t.height != th || t.x < 0 || t.y < 0 || t.x + t.width > width ||
        t.y + t.height > height || tw <= 0 || th <= 0) {
      return absl::InvalidArgumentError(absl::StrCat("cutout: tile ", t.x, ",", t.y, " ", t.width, "x",
                                                     t.height, " is not a ", tw, "x", th,
                                                     " tile inside the ", width, "x", height, " image"));
    }
    for (int y = 0; y < th; ++y) {
      const uint8_t* row = rgba.data() + (static_cast<size_t>(t.y + y) * width + t.x) * 4;
      uint8_t* out = mask.data() + static_cast<size_t>(y) * tw;
      for (int x = 0; x < tw; ++x) out[x] |= row[x * 4 + 3] != 0;
    }
  }
  return CutoutFromMask(mask, tw, th, max_vertices);
}

}  // namespace impostor
