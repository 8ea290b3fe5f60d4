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

// Gaussian 11 x 11, sigma 1.5 (Wang et al. 2004), applied separably; each
// pass divides by the weights that fell inside the image, which for a
// product kernel equals renormalising the clipped 2-D window.
class GaussianWindow {
 public:
  static constexpr int kRadius = 5;

  GaussianWindow(int w, int h) : w_(w), h_(h), tmp_(static_cast<size_t>(w) * h) {
    constexpr double kSigma = 1.5;
    for (int i = -kRadius; i <= kRadius; ++i) kernel_[i + kRadius] = std::exp(-(i * i) / (2 * kSigma * kSigma));
    inside_x_ = InsideWeights(w);
    inside_y_ = InsideWeights(h);
  }

  // out = blur(in). Each pixel's taps are summed in the same order (k from
  // -kRadius up) whatever the loop, so the figures do not depend on it; the
  // interior's taps are unrolled with the sum in a register (the metrics
  // were the quality pass's largest CPU cost on a GPU host).
  void Blur(const std::vector<double>& in, std::vector<double>& out) {
    out.resize(static_cast<size_t>(w_) * h_);
    for (int y = 0; y < h_; ++y) {
      const double* __restrict src = in.data() + static_cast<size_t>(y) * w_;
      double* __restrict dst = tmp_.data() + static_cast<size_t>(y) * w_;
      for (int x = 0; x < w_; ++x) {
        double sum = 0;
        if (x >= kRadius && x < w_ - kRadius) {
#pragma GCC unroll 11
          for (int k = -kRadius; k <= kRadius; ++k) sum += kernel_[k + kRadius] * src[x + k];
        } else {
          for (int k = std::max(-kRadius, -x); k <= std::min(kRadius, w_ - 1 - x); ++k) {
            sum += kernel_[k + kRadius] * src[x + k];
          }
        }
        dst[x] = sum / inside_x_[x];
      }
    }
    for (int y = 0; y < h_; ++y) {
      const int first = std::max(-kRadius, -y), last = std::min(kRadius, h_ - 1 - y);
      const double* __restrict rows = tmp_.data() + static_cast<ptrdiff_t>(y) * w_;
      double* __restrict dst = out.data() + static_cast<size_t>(y) * w_;
      if (first == -kRadius && last == kRadius) {
        for (int x = 0; x < w_; ++x) {
          double sum = 0;
#pragma GCC unroll 11
          for (int k = -kRadius; k <= kRadius; ++k) sum += kernel_[k + kRadius] * rows[static_cast<ptrdiff_t>(k) * w_ + x];
          dst[x] = sum / inside_y_[y];
        }
      } else {
        for (int x = 0; x < w_; ++x) {
          double sum = 0;
          for (int k = first; k <= last; ++k) sum += kernel_[k + kRadius] * rows[static_cast<ptrdiff_t>(k) * w_ + x];
          dst[x] = sum / inside_y_[y];
        }
      }
    }
  }

 private:
  // For each position along a side of `size`, the sum of the kernel's
  // weights whose taps fall inside, added in tap order.
  std::vector<double> InsideWeights(int size) const {
    std::vector<double> inside(size);
    for (int i = 0; i < size; ++i) {
      double weight = 0;
      for (int k = std::max(-kRadius, -i); k <= std::min(kRadius, size - 1 - i); ++k) weight += kernel_[k + kRadius];
      inside[i] = weight;
    }
    return inside;
  }

  int w_, h_;
  double kernel_[2 * kRadius + 1];
  std::vector<double> inside_x_, inside_y_;
  std::vector<double> tmp_;
};

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

// The buffers of one SSIM (the five windowed moments and their inputs),
// kept across the two SSIMs of a CompareViews: each is a page-sized
// allocation that the 16 threads of a quality pass otherwise fault in anew.
struct SsimScratch {
  SsimScratch(int w, int h) : window(w, h) {
    const size_t n = static_cast<size_t>(w) * h;
    for (std::vector<double>* v : {&m, &x, &y, &xx, &yy, &xy}) v->assign(n, 0.0);
  }
  GaussianWindow window;
  std::vector<double> m, x, y, xx, yy, xy;        // mask and the moments' inputs
  std::vector<double> wm, mx, my, exx, eyy, exy;  // their windowed sums
};

double Luma(const ViewPixels& v, size_t p) {
  return (0.299 * v.albedo_alpha[p * 4] + 0.587 * v.albedo_alpha[p * 4 + 1] + 0.114 * v.albedo_alpha[p * 4 + 2]) /
         255.0;
}

double AlbedoSsim(const ViewPixels& a, const ViewPixels& b, SsimScratch& s) {
  AssertSameSize(a, b);
  const size_t n = PixelCount(a);
  for (size_t p = 0; p < n; ++p) {
    s.x[p] = 0.299 * Composited(a, p, 0) + 0.587 * Composited(a, p, 1) + 0.114 * Composited(a, p, 2);
    s.y[p] = 0.299 * Composited(b, p, 0) + 0.587 * Composited(b, p, 1) + 0.114 * Composited(b, p, 2);
    s.xx[p] = s.x[p] * s.x[p];
    s.yy[p] = s.y[p] * s.y[p];
    s.xy[p] = s.x[p] * s.y[p];
  }
  s.window.Blur(s.x, s.mx);
  s.window.Blur(s.y, s.my);
  s.window.Blur(s.xx, s.exx);
  s.window.Blur(s.yy, s.eyy);
  s.window.Blur(s.xy, s.exy);
  constexpr double kC1 = 0.01 * 0.01, kC2 = 0.03 * 0.03;  // (K L)^2 with L = 1
  double sum = 0;
  int64_t either = 0;
  for (size_t p = 0; p < n; ++p) {
    if (!Covered(a, p) && !Covered(b, p)) continue;
    const double mx = s.mx[p], my = s.my[p];
    const double vx = s.exx[p] - mx * mx, vy = s.eyy[p] - my * my, cxy = s.exy[p] - mx * my;
    sum += ((2 * mx * my + kC1) * (2 * cxy + kC2)) / ((mx * mx + my * my + kC1) * (vx + vy + kC2));
    ++either;
  }
  return either == 0 ? 1.0 : sum / static_cast<double>(either);
}

double AlbedoSsimShared(const ViewPixels& a, const ViewPixels& b, SsimScratch& s) {
  AssertSameSize(a, b);
  const size_t n = PixelCount(a);
  int64_t both = 0, either = 0;
  for (size_t p = 0; p < n; ++p) {
    const bool ca = Covered(a, p), cb = Covered(b, p);
    either += ca || cb;
    if (!(ca && cb)) {
      s.m[p] = s.x[p] = s.y[p] = s.xx[p] = s.yy[p] = s.xy[p] = 0.0;
      continue;
    }
    ++both;
    const double lx = Luma(a, p), ly = Luma(b, p);
    s.m[p] = 1.0;
    s.x[p] = lx;
    s.y[p] = ly;
    s.xx[p] = lx * lx;
    s.yy[p] = ly * ly;
    s.xy[p] = lx * ly;
  }
  if (both == 0) return either == 0 ? 1.0 : 0.0;
  // Windows restricted to the shared pixels: blur(mask * v) / blur(mask).
  s.window.Blur(s.m, s.wm);
  s.window.Blur(s.x, s.mx);
  s.window.Blur(s.y, s.my);
  s.window.Blur(s.xx, s.exx);
  s.window.Blur(s.yy, s.eyy);
  s.window.Blur(s.xy, s.exy);
  constexpr double kC1 = 0.01 * 0.01, kC2 = 0.03 * 0.03;
  double sum = 0;
  for (size_t p = 0; p < n; ++p) {
    if (s.m[p] == 0.0) continue;
    const double inv = 1.0 / s.wm[p];
    const double ux = s.mx[p] * inv, uy = s.my[p] * inv;
    const double vx = s.exx[p] * inv - ux * ux, vy = s.eyy[p] * inv - uy * uy, cxy = s.exy[p] * inv - ux * uy;
    sum += ((2 * ux * uy + kC1) * (2 * cxy + kC2)) / ((ux * ux + uy * uy + kC1) * (vx + vy + kC2));
  }
  return sum / static_cast<double>(both);
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
  SsimScratch scratch(a.width, a.height);
  return AlbedoSsimShared(a, b, scratch);
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

double SilhouetteIouOutsideEdge(const ViewPixels& mesh, const ViewPixels& test) {
  AssertSameSize(mesh, test);
  int64_t both = 0, either = 0;
  for (size_t p = 0; p < PixelCount(mesh); ++p) {
    const uint8_t a = mesh.albedo_alpha[p * 4 + 3];
    if (a >= 85 && a < 170) continue;  // coverage in [1/3, 2/3): the mesh's own edge
    const bool ca = Covered(mesh, p), cb = Covered(test, p);
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
  SsimScratch scratch(a.width, a.height);
  return AlbedoSsim(a, b, scratch);
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
  SsimScratch scratch(reference.width, reference.height);
  m.albedo_ssim = AlbedoSsim(reference, test, scratch);
  m.albedo_psnr_shared_db = AlbedoPsnrSharedDb(reference, test);
  m.albedo_ssim_shared = AlbedoSsimShared(reference, test, scratch);
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
