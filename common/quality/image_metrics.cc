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

}  // namespace

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
  const GeometryErrors g = Geometry(reference, test);
  m.normal_error_deg_mean = g.normal_deg_mean;
  m.normal_error_deg_max = g.normal_deg_max;
  m.depth_error_mean = g.depth_mean;
  m.depth_error_max = g.depth_max;
  return m;
}

}  // namespace impostor
