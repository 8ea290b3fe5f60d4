#include "common/request/lod_parameters.h"

#include <cmath>
#include <cstdio>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

// Shortest text that reads back as the same float ("%.9g" round-trips).
std::string ExactFloat(float v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.9g", static_cast<double>(v));
  return buf;
}

}  // namespace

absl::Status NormalizeLodParameters(const v1::BakeParameters& in, v1::BakeParameters* out) {
  if (out->product() != v1::PRODUCT_LOD_CHAIN) {
    if (in.lod_ratios_size() > 0) {
      return absl::InvalidArgumentError("parameters.lod_ratios: only for product PRODUCT_LOD_CHAIN");
    }
    if (in.has_lod_pixel_error()) {
      return absl::InvalidArgumentError("parameters.lod_pixel_error: only for product PRODUCT_LOD_CHAIN");
    }
    return absl::OkStatus();
  }
  if (in.lod_ratios_size() > kMaxLodRatios) {
    return absl::InvalidArgumentError(absl::StrCat("parameters.lod_ratios: ", in.lod_ratios_size(),
                                                   " levels is more than the limit of ", kMaxLodRatios));
  }
  if (in.lod_ratios_size() == 0) {
    for (float r : kDefaultLodRatios) out->add_lod_ratios(r);
  }
  for (int i = 0; i < out->lod_ratios_size(); ++i) {
    const float r = out->lod_ratios(i);
    const std::string field = absl::StrCat("parameters.lod_ratios[", i, "]");
    if (!std::isfinite(r) || r <= 0.0f || r >= 1.0f) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ": ", ExactFloat(r), " is outside the open range (0, 1)"));
    }
    if (i > 0 && r >= out->lod_ratios(i - 1)) {
      return absl::InvalidArgumentError(absl::StrCat(
          field, ": ", ExactFloat(r), " must be smaller than parameters.lod_ratios[", i - 1, "] (",
          ExactFloat(out->lod_ratios(i - 1)), "); ratios must be strictly decreasing"));
    }
  }
  if (!in.has_lod_pixel_error()) out->set_lod_pixel_error(kDefaultLodPixelError);
  const float e = out->lod_pixel_error();
  if (!std::isfinite(e) || e < kMinLodPixelError || e > kMaxLodPixelError) {
    return absl::InvalidArgumentError(absl::StrCat("parameters.lod_pixel_error: ", ExactFloat(e),
                                                   " is out of range 0.1..16"));
  }
  return absl::OkStatus();
}

std::string LodCacheKeyLine(const v1::BakeParameters& normalized) {
  std::string line = "lod_ratios";
  for (float r : normalized.lod_ratios()) absl::StrAppend(&line, " ", ExactFloat(r));
  absl::StrAppend(&line, " lod_pixel_error ", ExactFloat(normalized.lod_pixel_error()));
  return line;
}

}  // namespace impostor
