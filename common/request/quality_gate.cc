#include "common/request/quality_gate.h"

#include <cmath>
#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace impostor {

bool HasQualityGate(const v1::QualityGate& gate) { return gate.has_min_iou() || gate.has_min_psnr_db(); }

absl::Status ValidateQualityGate(const v1::QualityGate& gate, const char* field) {
  // Written as "inside" so that NaN fails too.
  if (gate.has_min_iou() && !(gate.min_iou() >= 0.0f && gate.min_iou() <= 1.0f)) {
    return absl::InvalidArgumentError(absl::StrCat(field, ".min_iou: ", gate.min_iou(), " is out of range 0..1"));
  }
  if (gate.has_min_psnr_db() && !(gate.min_psnr_db() >= 0.0f && gate.min_psnr_db() <= 100.0f)) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ".min_psnr_db: ", gate.min_psnr_db(), " is out of range 0..100"));
  }
  return absl::OkStatus();
}

absl::Status CheckQualityGateApplies(const v1::QualityGate& gate, const v1::BakeParameters& normalized,
                                     const char* field) {
  if (!HasQualityGate(gate)) return absl::OkStatus();
  const v1::Product product = normalized.product();
  if (product != v1::PRODUCT_ATLAS && product != v1::PRODUCT_LOD_CHAIN) {
    return absl::InvalidArgumentError(absl::StrCat(
        field, ": only atlas and lod-chain bakes are gated (their quality pass measures what min_iou and "
               "min_psnr_db judge); this request's product is ", v1::Product_Name(product)));
  }
  if (normalized.quality_views() == 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        field, ": needs the quality pass, and this request turns it off (parameters.quality_views 0)"));
  }
  return absl::OkStatus();
}

absl::Status CheckQualityGate(const v1::QualityGate& gate, const v1::Manifest& result) {
  if (!HasQualityGate(gate)) return absl::OkStatus();
  const v1::AtlasQuality& q = result.quality();
  if (!result.has_quality() || q.views() == 0) {
    return absl::FailedPreconditionError("quality gate: the result has no quality measurement");
  }
  // %g keeps "0.95" and "30" as people wrote them; measured values get
  // enough digits to see how far off they are.
  std::string message = "quality gate: ";
  bool failed = false;
  auto add = [&](const std::string& part) {
    if (message.back() != ' ') message += "; ";
    message += part;
  };
  if (gate.has_min_iou()) {
    const bool ok = q.silhouette_iou_mean() >= gate.min_iou();
    failed |= !ok;
    add(absl::StrFormat("silhouette IoU %.3f %s min_iou %g", q.silhouette_iou_mean(), ok ? ">=" : "<",
                        gate.min_iou()));
  }
  if (gate.has_min_psnr_db()) {
    const bool ok = q.albedo_psnr_shared_db_mean() >= gate.min_psnr_db();
    failed |= !ok;
    add(absl::StrFormat("albedo PSNR %.1f dB %s min_psnr_db %g", q.albedo_psnr_shared_db_mean(), ok ? ">=" : "<",
                        gate.min_psnr_db()));
  }
  if (!failed) return absl::OkStatus();
  return absl::FailedPreconditionError(message);
}

}  // namespace impostor
