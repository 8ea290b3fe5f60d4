#include "common/request/card_parameters.h"

#include <cmath>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace impostor {

absl::Status NormalizeCardParameters(const v1::BakeParameters& in, v1::BakeParameters* out) {
  if (out->product() != v1::PRODUCT_CARDS) {
    if (in.has_max_planes()) {
      return absl::InvalidArgumentError("parameters.max_planes: only for product PRODUCT_CARDS");
    }
    if (in.has_tolerance()) {
      return absl::InvalidArgumentError("parameters.tolerance: only for product PRODUCT_CARDS");
    }
    return absl::OkStatus();
  }
  if (in.frames() != 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "parameters.frames: ", in.frames(), " given, but product PRODUCT_CARDS renders no views; leave it unset"));
  }
  // Clients send their default layout with every request; cards have no
  // views, so any layout is accepted and the same one is keyed.
  out->set_layout(v1::LAYOUT_OCTAHEDRAL);
  if (!in.has_max_planes()) out->set_max_planes(kDefaultMaxPlanes);
  if (out->max_planes() < kMinMaxPlanes || out->max_planes() > kMaxMaxPlanes) {
    return absl::InvalidArgumentError(absl::StrCat("parameters.max_planes: ", out->max_planes(),
                                                   " is out of range ", kMinMaxPlanes, "..", kMaxMaxPlanes));
  }
  if (!in.has_tolerance()) out->set_tolerance(kDefaultCardTolerance);
  const float t = out->tolerance();
  if (!std::isfinite(t) || t < kMinCardTolerance || t > kMaxCardTolerance) {
    return absl::InvalidArgumentError(absl::StrCat("parameters.tolerance: ", t,
                                                   " is out of range 0.0001..1 (a fraction of the "
                                                   "bounding-sphere radius)"));
  }
  if (out->resolution() == 0) out->set_resolution(kDefaultCardResolution);
  out->set_frames(2);
  return absl::OkStatus();
}

std::string CardCacheKeyLine(const v1::BakeParameters& p) {
  const float t = p.tolerance();
  uint32_t bits = 0;
  std::memcpy(&bits, &t, sizeof(bits));
  return absl::StrCat("max_planes ", p.max_planes(), " tolerance ", absl::StrFormat("0x%08x", bits));
}

}  // namespace impostor
