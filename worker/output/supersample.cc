#include "worker/output/supersample.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

const std::array<float, 256>& SrgbToLinear() {
  static const std::array<float, 256> table = [] {
    std::array<float, 256> t{};
    for (int i = 0; i < 256; ++i) {
      const float c = static_cast<float>(i) / 255.0f;
      t[static_cast<size_t>(i)] = c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
    }
    return t;
  }();
  return table;
}

uint8_t LinearToSrgb8(float l) {
  l = std::clamp(l, 0.0f, 1.0f);
  const float c = l <= 0.0031308f ? l * 12.92f : 1.055f * std::pow(l, 1.0f / 2.4f) - 0.055f;
  return static_cast<uint8_t>(std::lround(c * 255.0f));
}

uint8_t Round8(double v) { return static_cast<uint8_t>(std::clamp(std::lround(v), 0L, 255L)); }
uint16_t Round16(double v) { return static_cast<uint16_t>(std::clamp(std::lround(v), 0L, 65535L)); }

}  // namespace

absl::Status DownsampleMaps(int factor, AtlasMaps* maps) {
  const int w = maps->width, h = maps->height;
  const size_t n = static_cast<size_t>(std::max(w, 0)) * std::max(h, 0);
  if (factor < 1 || w < 1 || h < 1 || w % factor != 0 || h % factor != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("supersampling: a ", w, "x", h, " image cannot be reduced by ", factor));
  }
  const bool emissive_in = !maps->emissive.empty();
  if (maps->albedo_alpha.size() != n * 4 || maps->normal_depth.size() != n * 4 || maps->orm.size() != n * 4 ||
      (emissive_in && maps->emissive.size() != n * 4)) {
    return absl::InvalidArgumentError(absl::StrCat("supersampling: buffers do not match ", w, "x", h, " RGBA"));
  }
  if (factor == 1) return absl::OkStatus();
  const auto& lin = SrgbToLinear();
  const int ow = w / factor, oh = h / factor;
  const size_t on = static_cast<size_t>(ow) * oh;
  std::vector<uint8_t> albedo(on * 4, 0), orm(on * 4, 0), emissive(emissive_in ? on * 4 : 0, 0);
  std::vector<uint16_t> normal_depth(on * 4, 0);
  const int samples = factor * factor;
  for (int oy = 0; oy < oh; ++oy) {
    for (int ox = 0; ox < ow; ++ox) {
      int covered = 0;
      double rgb[3] = {0, 0, 0}, nrm[3] = {0, 0, 0}, depth = 0, o[3] = {0, 0, 0}, e[3] = {0, 0, 0};
      for (int sy = 0; sy < factor; ++sy) {
        for (int sx = 0; sx < factor; ++sx) {
          const size_t i = static_cast<size_t>(oy * factor + sy) * w + ox * factor + sx;
          if (maps->albedo_alpha[i * 4 + 3] == 0) continue;
          ++covered;
          for (int c = 0; c < 3; ++c) {
            rgb[c] += lin[maps->albedo_alpha[i * 4 + c]];
            nrm[c] += maps->normal_depth[i * 4 + c] / 65535.0 * 2.0 - 1.0;
            o[c] += maps->orm[i * 4 + c];
            if (emissive_in) e[c] += lin[maps->emissive[i * 4 + c]];
          }
          depth += maps->normal_depth[i * 4 + 3];
        }
      }
      const size_t out = static_cast<size_t>(oy) * ow + ox;
      if (covered == 0) {
        for (int c = 0; c < 3; ++c) normal_depth[out * 4 + c] = 32768;
        normal_depth[out * 4 + 3] = 65535;
        continue;
      }
      const uint8_t coverage = Round8(255.0 * covered / samples);
      const double len = std::sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
      for (int c = 0; c < 3; ++c) {
        albedo[out * 4 + c] = LinearToSrgb8(static_cast<float>(rgb[c] / covered));
        orm[out * 4 + c] = Round8(o[c] / covered);
        if (emissive_in) emissive[out * 4 + c] = LinearToSrgb8(static_cast<float>(e[c] / covered));
        const double unit = len > 1e-9 ? nrm[c] / len : (c == 2 ? 1.0 : 0.0);
        normal_depth[out * 4 + c] = Round16((unit * 0.5 + 0.5) * 65535.0);
      }
      albedo[out * 4 + 3] = coverage;
      orm[out * 4 + 3] = coverage;
      if (emissive_in) emissive[out * 4 + 3] = coverage;
      normal_depth[out * 4 + 3] = Round16(depth / covered);
    }
  }
  maps->width = ow;
  maps->height = oh;
  maps->albedo_alpha = std::move(albedo);
  maps->normal_depth = std::move(normal_depth);
  maps->orm = std::move(orm);
  maps->emissive = std::move(emissive);
  return absl::OkStatus();
}

}  // namespace impostor
