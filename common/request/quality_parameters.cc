#include "common/request/quality_parameters.h"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "common/request/auto_frames_ladder.h"
#include "common/request/quality_gate.h"

namespace impostor {
namespace {

bool IsAtlasProduct(v1::Product p) { return p == v1::PRODUCT_ATLAS || p == v1::PRODUCT_LOD_CHAIN; }

}  // namespace

absl::Status NormalizeQualityParameters(const v1::BakeParameters& in, v1::BakeParameters* out) {
  if (!IsAtlasProduct(out->product())) {
    const char* field = in.has_quality_views() ? "quality_views"
                        : in.frames_auto()     ? "frames_auto"
                        : in.has_auto_target() ? "auto_target"
                                               : nullptr;
    if (field == nullptr) return absl::OkStatus();
    return absl::InvalidArgumentError(
        absl::StrCat("parameters.", field, ": only for products PRODUCT_ATLAS and PRODUCT_LOD_CHAIN"));
  }
  if (!in.has_quality_views()) out->set_quality_views(kDefaultQualityViewCount);
  if (out->quality_views() > kMaxQualityViewCount) {
    return absl::InvalidArgumentError(absl::StrCat("parameters.quality_views: ", out->quality_views(),
                                                   " is out of range 0..", kMaxQualityViewCount));
  }
  if (!in.frames_auto()) {
    if (in.has_auto_target()) {
      return absl::InvalidArgumentError("parameters.auto_target: only with frames_auto");
    }
    return absl::OkStatus();
  }
  if (in.frames() != 0) {
    return absl::InvalidArgumentError(absl::StrCat("parameters.frames: must be unset with frames_auto (the baker picks it from ",
                                                   AutoFramesLadderText(out->layout()), "); got ", in.frames()));
  }
  // Ring-top's knob is its view count: the ladder turns ring_views.
  if (out->layout() == v1::LAYOUT_RING_TOP && in.has_ring_views()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "parameters.ring_views: must be unset with frames_auto (the baker picks it from ",
        AutoFramesLadderText(v1::LAYOUT_RING_TOP), "); got ", in.ring_views()));
  }
  if (!HasQualityGate(in.auto_target())) {
    return absl::InvalidArgumentError(
        "parameters.auto_target: frames_auto needs at least one threshold (min_iou or min_psnr_db)");
  }
  if (auto s = ValidateQualityGate(in.auto_target(), "parameters.auto_target"); !s.ok()) return s;
  if (out->quality_views() == 0) {
    return absl::InvalidArgumentError("parameters.quality_views: frames_auto needs the quality pass; got 0");
  }
  return absl::OkStatus();
}

std::string QualityCacheKeyLine(const v1::BakeParameters& p) {
  const bool default_views = !p.has_quality_views() || p.quality_views() == kDefaultQualityViewCount;
  if (default_views && !p.frames_auto()) return "";
  std::string line = absl::StrCat("quality_views ", p.has_quality_views() ? p.quality_views() : kDefaultQualityViewCount);
  if (p.frames_auto()) {
    // %.9g round-trips a float: two different thresholds never share a key.
    const v1::QualityGate& t = p.auto_target();
    absl::StrAppend(&line, " frames_auto min_iou ", t.has_min_iou() ? absl::StrFormat("%.9g", t.min_iou()) : "-",
                    " min_psnr_db ", t.has_min_psnr_db() ? absl::StrFormat("%.9g", t.min_psnr_db()) : "-");
  }
  return line;
}

}  // namespace impostor
