#include "common/quality/image_metrics.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <numbers>
#include <vector>

namespace impostor {
namespace {

constexpr uint8_t kCoveredAlpha = 128;

bool Covered(const ViewPixels& v, size_t pixel) { return v.albedo_alpha[pixel * 4 + 3] >= kCoveredAlpha; }

size_t PixelCount(const ViewPixels& v) { return static_cast<size_t>(v.width) * static_cast<size_t>(v.height); }

void AssertSameSize(const ViewPixels& a, const ViewPixels& b) {
  assert(a.width == b.width && a.height == b.height);
  assert(a.albedo_alpha.size() == PixelCount(a) * 4 && b.albedo_alpha.size() == PixelCount(b) * 4);
  (void)a;
  (void)b;
}

// Channel c of pixel p composited over black, 0..1.
double Composited(const ViewPixels& v, size_t p, int c) {
  return Covered(v, p) ? v.albedo_alpha[p * 4 + c] / 255.0 : 0.0;
}

// Luminance of the image composited over black (Rec. 601 weights).
std::vector<double> Luminance(const ViewPixels& v) {
  std::vector<double> y(PixelCount(v));
  for (size_t p = 0; p < y.size(); ++p) {
    y[p] = 0.299 * Composited(v, p, 0) + 0.587 * Composited(v, p, 1) + 0.114 * Composited(v, p, 2);
  }
  return y;
}

// Gaussian 11 x 11, sigma 1.5 (Wang et al. 2004), applied separably; each
// pass divides by the weights that fell inside the image, which for a
// product kernel equals renormalising the clipped 2-D window.
std::vector<double> GaussianBlur(const std::vector<double>& in, int w, int h) {
  constexpr int kRadius = 5;
  constexpr double kSigma = 1.5;
  double kernel[2 * kRadius + 1];
  for (int i = -kRadius; i <= kRadius; ++i) kernel[i + kRadius] = std::exp(-(i * i) / (2 * kSigma * kSigma));
  std::vector<double> tmp(in.size()), out(in.size());
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      double sum = 0, weight = 0;
      for (int k = std::max(-kRadius, -x); k <= std::min(kRadius, w - 1 - x); ++k) {
        sum += kernel[k + kRadius] * in[static_cast<size_t>(y) * w + x + k];
        weight += kernel[k + kRadius];
      }
      tmp[static_cast<size_t>(y) * w + x] = sum / weight;
    }
  }
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      double sum = 0, weight = 0;
      for (int k = std::max(-kRadius, -y); k <= std::min(kRadius, h - 1 - y); ++k) {
        sum += kernel[k + kRadius] * tmp[static_cast<size_t>(y + k) * w + x];
        weight += kernel[k + kRadius];
      }
      out[static_cast<size_t>(y) * w + x] = sum / weight;
    }
  }
  return out;
}

struct GeometryErrors {
  double normal_deg_mean = 0, normal_deg_max = 0, depth_mean = 0, depth_max = 0;
};

GeometryErrors Geometry(const ViewPixels& a, const ViewPixels& b) {
  GeometryErrors g;
  const size_t n = PixelCount(a);
  if (a.normal_depth.size() != n * 4 || b.normal_depth.size() != n * 4) return g;
  int64_t both = 0;
  double normal_sum = 0, depth_sum = 0;
  for (size_t p = 0; p < n; ++p) {
    if (!Covered(a, p) || !Covered(b, p)) continue;
    double na[3], nb[3], la = 0, lb = 0, dot = 0;
    for (int c = 0; c < 3; ++c) {
      na[c] = a.normal_depth[p * 4 + c] / 65535.0 * 2.0 - 1.0;
      nb[c] = b.normal_depth[p * 4 + c] / 65535.0 * 2.0 - 1.0;
      la += na[c] * na[c];
      lb += nb[c] * nb[c];
      dot += na[c] * nb[c];
    }
    // A degenerate (zero) normal counts as perpendicular: the worst
    // plausible answer rather than a NaN.
    const double cosine = (la > 0 && lb > 0) ? std::clamp(dot / std::sqrt(la * lb), -1.0, 1.0) : 0.0;
    const double degrees = std::acos(cosine) * 180.0 / std::numbers::pi;
    // One unit of encoded depth is 2 radii (see the header).
    const double depth = 2.0 * std::abs(a.normal_depth[p * 4 + 3] / 65535.0 - b.normal_depth[p * 4 + 3] / 65535.0);
    normal_sum += degrees;
    depth_sum += depth;
    g.normal_deg_max = std::max(g.normal_deg_max, degrees);
    g.depth_max = std::max(g.depth_max, depth);
    ++both;
  }
  if (both > 0) {
    g.normal_deg_mean = normal_sum / static_cast<double>(both);
    g.depth_mean = depth_sum / static_cast<double>(both);
  }
  return g;
}

// Squared Euclidean distance transform in one dimension (Felzenszwalb &
// Huttenlocher, "Distance Transforms of Sampled Functions", 2012): f is
// 0 on seeds and kFar elsewhere; returns min_q (p - q)^2 + f(q).
constexpr double kFar = 1e20;
void DistanceTransform1d(const std::vector<double>& f, std::vector<double>& d) {
  const int n = static_cast<int>(f.size());
  std::vector<int> v(n);
  std::vector<double> z(n + 1);
  int k = 0;
  v[0] = 0;
  z[0] = -kFar;
  z[1] = kFar;
  for (int q = 1; q < n; ++q) {
    double s = 0;
    while (true) {
      s = ((f[q] + static_cast<double>(q) * q) - (f[v[k]] + static_cast<double>(v[k]) * v[k])) / (2.0 * q - 2.0 * v[k]);
      if (s > z[k] || k == 0) break;
      --k;
    }
    if (s <= z[k]) {  // k == 0 and the parabola at v[0] is beaten everywhere
      v[0] = q;
      z[0] = -kFar;
      z[1] = kFar;
      continue;
    }
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = kFar;
  }
  d.assign(n, 0.0);
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[k + 1] < q) ++k;
    d[q] = static_cast<double>(q - v[k]) * (q - v[k]) + f[v[k]];
  }
}

// Distance (pixels) from every pixel to the nearest seed; kFar-ish without seeds.
std::vector<double> DistanceToSeeds(const std::vector<bool>& seed, int w, int h) {
  std::vector<double> grid(seed.size());
  for (size_t p = 0; p < seed.size(); ++p) grid[p] = seed[p] ? 0.0 : kFar;
  std::vector<double> f, d;
  for (int x = 0; x < w; ++x) {
    f.resize(h);
    for (int y = 0; y < h; ++y) f[y] = grid[static_cast<size_t>(y) * w + x];
    DistanceTransform1d(f, d);
    for (int y = 0; y < h; ++y) grid[static_cast<size_t>(y) * w + x] = d[y];
  }
  for (int y = 0; y < h; ++y) {
    f.assign(grid.begin() + static_cast<ptrdiff_t>(y) * w, grid.begin() + static_cast<ptrdiff_t>(y + 1) * w);
    DistanceTransform1d(f, d);
    for (int x = 0; x < w; ++x) grid[static_cast<size_t>(y) * w + x] = std::sqrt(d[x]);
  }
  return grid;
}

// Silhouette boundary: covered pixels with an uncovered 4-neighbour or on
// the image border.
std::vector<bool> Boundary(const ViewPixels& v) {
  const int w = v.width, h = v.height;
  std::vector<bool> b(PixelCount(v), false);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t p = static_cast<size_t>(y) * w + x;
      if (!Covered(v, p)) continue;
      b[p] = x == 0 || y == 0 || x == w - 1 || y == h - 1 || !Covered(v, p - 1) || !Covered(v, p + 1) ||
             !Covered(v, p - w) || !Covered(v, p + w);
    }
  }
  return b;
}

}  // namespace

double AlbedoPsnrSharedDb(const ViewPixels& a, const ViewPixels& b) {
  AssertSameSize(a, b);
  double squared = 0;
  int64_t both = 0, either = 0;
  for (size_t p = 0; p < PixelCount(a); ++p) {
    const bool ca = Covered(a, p), cb = Covered(b, p);
    either += ca || cb;
    if (!(ca && cb)) continue;
    ++both;
    for (int c = 0; c < 3; ++c) {
      const double d = (a.albedo_alpha[p * 4 + c] - b.albedo_alpha[p * 4 + c]) / 255.0;
      squared += d * d;
    }
  }
  if (both == 0) return either == 0 ? kMaxPsnrDb : 0.0;
  return PsnrFromMse(squared / (3.0 * static_cast<double>(both)));
}

double AlbedoSsimShared(const ViewPixels& a, const ViewPixels& b) {
  AssertSameSize(a, b);
  const int w = a.width, h = a.height;
  const size_t n = PixelCount(a);
  std::vector<double> m(n), x(n), y(n), xx(n), yy(n), xy(n);
  int64_t both = 0, either = 0;
  for (size_t p = 0; p < n; ++p) {
    const bool ca = Covered(a, p), cb = Covered(b, p);
    either += ca || cb;
    if (!(ca && cb)) continue;
    ++both;
    const double lx = (0.299 * a.albedo_alpha[p * 4] + 0.587 * a.albedo_alpha[p * 4 + 1] +
                       0.114 * a.albedo_alpha[p * 4 + 2]) / 255.0;
    const double ly = (0.299 * b.albedo_alpha[p * 4] + 0.587 * b.albedo_alpha[p * 4 + 1] +
                       0.114 * b.albedo_alpha[p * 4 + 2]) / 255.0;
    m[p] = 1.0;
    x[p] = lx;
    y[p] = ly;
    xx[p] = lx * lx;
    yy[p] = ly * ly;
    xy[p] = lx * ly;
  }
  if (both == 0) return either == 0 ? 1.0 : 0.0;
  // Windows restricted to the shared pixels: blur(mask * v) / blur(mask).
  const std::vector<double> wm = GaussianBlur(m, w, h);
  const std::vector<double> mx = GaussianBlur(x, w, h), my = GaussianBlur(y, w, h);
  const std::vector<double> exx = GaussianBlur(xx, w, h), eyy = GaussianBlur(yy, w, h), exy = GaussianBlur(xy, w, h);
  constexpr double kC1 = 0.01 * 0.01, kC2 = 0.03 * 0.03;
  double sum = 0;
  for (size_t p = 0; p < n; ++p) {
    if (m[p] == 0.0) continue;
    const double inv = 1.0 / wm[p];
    const double ux = mx[p] * inv, uy = my[p] * inv;
    const double vx = exx[p] * inv - ux * ux, vy = eyy[p] * inv - uy * uy, cxy = exy[p] * inv - ux * uy;
    sum += ((2 * ux * uy + kC1) * (2 * cxy + kC2)) / ((ux * ux + uy * uy + kC1) * (vx + vy + kC2));
  }
  return sum / static_cast<double>(both);
}

BoundaryError SilhouetteBoundaryError(const ViewPixels& a, const ViewPixels& b) {
  AssertSameSize(a, b);
  BoundaryError e;
  const std::vector<bool> ba = Boundary(a), bb = Boundary(b);
  const bool any_a = std::find(ba.begin(), ba.end(), true) != ba.end();
  const bool any_b = std::find(bb.begin(), bb.end(), true) != bb.end();
  if (!any_a && !any_b) return e;
  const double cap = std::hypot(a.width, a.height);
  if (!any_a || !any_b) {
    e.mean_px = e.max_px = cap;
    return e;
  }
  const std::vector<double> da = DistanceToSeeds(ba, a.width, a.height), db = DistanceToSeeds(bb, a.width, a.height);
  double sum = 0;
  int64_t count = 0;
  for (size_t p = 0; p < ba.size(); ++p) {
    if (ba[p]) {
      sum += db[p];
      e.max_px = std::max(e.max_px, db[p]);
      ++count;
    }
    if (bb[p]) {
      sum += da[p];
      e.max_px = std::max(e.max_px, da[p]);
      ++count;
    }
  }
  e.mean_px = sum / static_cast<double>(count);
  return e;
}

double PsnrFromMse(double mse) {
  if (!(mse > 0.0)) return kMaxPsnrDb;
  return std::min(kMaxPsnrDb, -10.0 * std::log10(mse));
}

double SilhouetteIou(const ViewPixels& a, const ViewPixels& b) {
  AssertSameSize(a, b);
  int64_t both = 0, either = 0;
  for (size_t p = 0; p < PixelCount(a); ++p) {
    const bool ca = Covered(a, p), cb = Covered(b, p);
    both += ca && cb;
    either += ca || cb;
  }
  return either == 0 ? 1.0 : static_cast<double>(both) / static_cast<double>(either);
}

double AlbedoPsnrDb(const ViewPixels& a, const ViewPixels& b) {
  AssertSameSize(a, b);
  double squared = 0;
  int64_t either = 0;
  for (size_t p = 0; p < PixelCount(a); ++p) {
    if (!Covered(a, p) && !Covered(b, p)) continue;
    ++either;
    for (int c = 0; c < 3; ++c) {
      const double d = Composited(a, p, c) - Composited(b, p, c);
      squared += d * d;
    }
  }
  return either == 0 ? kMaxPsnrDb : PsnrFromMse(squared / (3.0 * static_cast<double>(either)));
}

double AlbedoSsim(const ViewPixels& a, const ViewPixels& b) {
  AssertSameSize(a, b);
  const int w = a.width, h = a.height;
  const size_t n = PixelCount(a);
  const std::vector<double> x = Luminance(a), y = Luminance(b);
  std::vector<double> xx(n), yy(n), xy(n);
  for (size_t p = 0; p < n; ++p) {
    xx[p] = x[p] * x[p];
    yy[p] = y[p] * y[p];
    xy[p] = x[p] * y[p];
  }
  const std::vector<double> mx = GaussianBlur(x, w, h), my = GaussianBlur(y, w, h);
  const std::vector<double> exx = GaussianBlur(xx, w, h), eyy = GaussianBlur(yy, w, h), exy = GaussianBlur(xy, w, h);
  constexpr double kC1 = 0.01 * 0.01, kC2 = 0.03 * 0.03;  // (K L)^2 with L = 1
  double sum = 0;
  int64_t either = 0;
  for (size_t p = 0; p < n; ++p) {
    if (!Covered(a, p) && !Covered(b, p)) continue;
    const double vx = exx[p] - mx[p] * mx[p], vy = eyy[p] - my[p] * my[p], cxy = exy[p] - mx[p] * my[p];
    sum += ((2 * mx[p] * my[p] + kC1) * (2 * cxy + kC2)) /
           ((mx[p] * mx[p] + my[p] * my[p] + kC1) * (vx + vy + kC2));
    ++either;
  }
  return either == 0 ? 1.0 : sum / static_cast<double>(either);
}

double MeanAbsoluteAlbedoChange(const ViewPixels& a, const ViewPixels& b) {
  AssertSameSize(a, b);
  double sum = 0;
  int64_t either = 0;
  for (size_t p = 0; p < PixelCount(a); ++p) {
    if (!Covered(a, p) && !Covered(b, p)) continue;
    ++either;
    for (int c = 0; c < 3; ++c) sum += std::abs(Composited(a, p, c) - Composited(b, p, c));
  }
  return either == 0 ? 0.0 : sum / (3.0 * static_cast<double>(either));
}

double PopRatio(std::span<const double> changes, std::span<const double> mesh_changes) {
  assert(changes.size() == mesh_changes.size());
  if (mesh_changes.empty()) return 0.0;
  double mesh_mean = 0;
  for (double c : mesh_changes) mesh_mean += c;
  mesh_mean /= static_cast<double>(mesh_changes.size());
  const double floor = std::max(0.25 * mesh_mean, 0.5 / 255.0);
  double pop = 0;
  for (size_t i = 0; i < changes.size(); ++i) pop = std::max(pop, changes[i] / std::max(mesh_changes[i], floor));
  return pop;
}

ViewMetrics CompareViews(const ViewPixels& reference, const ViewPixels& test) {
  AssertSameSize(reference, test);
  ViewMetrics m;
  for (size_t p = 0; p < PixelCount(reference); ++p) {
    const bool ca = Covered(reference, p), cb = Covered(test, p);
    m.both_pixels += ca && cb;
    m.union_pixels += ca || cb;
  }
  m.iou = SilhouetteIou(reference, test);
  m.albedo_psnr_db = AlbedoPsnrDb(reference, test);
  m.albedo_ssim = AlbedoSsim(reference, test);
  m.albedo_psnr_shared_db = AlbedoPsnrSharedDb(reference, test);
  m.albedo_ssim_shared = AlbedoSsimShared(reference, test);
  const BoundaryError boundary = SilhouetteBoundaryError(reference, test);
  m.boundary_error_px_mean = boundary.mean_px;
  m.boundary_error_px_max = boundary.max_px;
  const GeometryErrors g = Geometry(reference, test);
  m.normal_error_deg_mean = g.normal_deg_mean;
  m.normal_error_deg_max = g.normal_deg_max;
  m.depth_error_mean = g.depth_mean;
  m.depth_error_max = g.depth_max;
  return m;
}

}  // namespace impostor
