// What the quality pass's per-view metrics cost on the CPU: CompareViews of
// one pair of synthetic views (a shaded disc against the same disc shifted
// and tinted, normals and depth filled) at the pass's view sizes. The pass
// compares 16 pairs per mode on all cores beside the PNG encoders, so these
// milliseconds are what it takes from the bake's CPU.
//
//   metrics_bench [--runs N]
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <vector>

#include "bench/bench_args.h"
#include "bench/median_time.h"
#include "common/quality/image_metrics.h"

namespace {

struct View {
  int size = 0;
  std::vector<uint8_t> albedo_alpha;
  std::vector<uint16_t> normal_depth;
  impostor::ViewPixels Pixels() const { return {size, size, albedo_alpha, normal_depth}; }
};

// A disc of radius 0.4 * size centred at (0.5 + shift) * size, its colour a
// gradient with a little texture, its normal that of a sphere.
View Disc(int size, float shift, int tint) {
  View v{size, std::vector<uint8_t>(static_cast<size_t>(size) * size * 4, 0),
         std::vector<uint16_t>(static_cast<size_t>(size) * size * 4, 0)};
  const float c = (0.5f + shift) * static_cast<float>(size), r = 0.4f * static_cast<float>(size);
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const float dx = (static_cast<float>(x) - c) / r, dy = (static_cast<float>(y) - c) / r;
      const float d2 = dx * dx + dy * dy;
      if (d2 > 1.0f) continue;
      const size_t p = (static_cast<size_t>(y) * size + x) * 4;
      v.albedo_alpha[p] = static_cast<uint8_t>((x * 255 / size + tint) & 255);
      v.albedo_alpha[p + 1] = static_cast<uint8_t>((y * 255 / size) ^ ((x * 7) & 15));
      v.albedo_alpha[p + 2] = static_cast<uint8_t>(128 + tint);
      v.albedo_alpha[p + 3] = 255;
      const float dz = std::sqrt(1.0f - d2);
      v.normal_depth[p] = static_cast<uint16_t>((dx * 0.5f + 0.5f) * 65535.0f);
      v.normal_depth[p + 1] = static_cast<uint16_t>((dy * 0.5f + 0.5f) * 65535.0f);
      v.normal_depth[p + 2] = static_cast<uint16_t>((dz * 0.5f + 0.5f) * 65535.0f);
      v.normal_depth[p + 3] = static_cast<uint16_t>((0.5f - 0.5f * dz) * 65535.0f);
    }
  }
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  int runs = 21;
  impostor::bench::BenchArgs("metrics_bench", "CompareViews of one view pair at the quality pass's sizes.")
      .Int("--runs", &runs, "timed runs per size; the median is printed (default 21)")
      .ParseOrExit(argc, argv);
  std::printf("metrics_bench: CompareViews of one pair, median of %d runs, one thread\n", runs);
  std::printf("%6s %10s %12s\n", "pixels", "ms/pair", "ns/pixel");
  for (int size : {64, 128, 256, 512}) {
    const View a = Disc(size, 0.0f, 0), b = Disc(size, 0.01f, 6);
    double iou = 0;
    const double s = impostor::bench::MedianSeconds(runs, [&] { iou += impostor::CompareViews(a.Pixels(), b.Pixels()).iou; });
    std::printf("%6d %10.2f %12.1f%s\n", size, s * 1e3, s * 1e9 / (static_cast<double>(size) * size),
                iou > 0 ? "" : " (no overlap?)");
  }
  // The figures themselves, to every digit: a faster CompareViews must
  // print the same line.
  const View a = Disc(256, 0.0f, 0), b = Disc(256, 0.01f, 6);
  const impostor::ViewMetrics m = impostor::CompareViews(a.Pixels(), b.Pixels());
  std::printf("figures at 256: iou %.17g psnr %.17g ssim %.17g shared psnr %.17g shared ssim %.17g boundary %.17g / "
              "%.17g normal %.17g / %.17g depth %.17g / %.17g\n",
              m.iou, m.albedo_psnr_db, m.albedo_ssim, m.albedo_psnr_shared_db, m.albedo_ssim_shared,
              m.boundary_error_px_mean, m.boundary_error_px_max, m.normal_error_deg_mean, m.normal_error_deg_max,
              m.depth_error_mean, m.depth_error_max);
  return 0;
}
