// The quality gate of a bake request (impostor.v1.QualityGate): thresholds on
// the measured fidelity of an atlas result (Manifest.quality). Pure functions
// shared by the server (which judges every requester's result) and the client
// (which checks flags before sending them). Thread-safe.
#ifndef IMPOSTOR_COMMON_REQUEST_QUALITY_GATE_H_
#define IMPOSTOR_COMMON_REQUEST_QUALITY_GATE_H_

#include "absl/status/status.h"
#include "impostor/v1/types.pb.h"

namespace impostor {

// True when the gate sets at least one threshold.
bool HasQualityGate(const v1::QualityGate& gate);

// OK, or INVALID_ARGUMENT naming the field and its range: `field`.min_iou
// must be within 0..1 and `field`.min_psnr_db within 0..100 (NaN refused).
absl::Status ValidateQualityGate(const v1::QualityGate& gate, const char* field = "gate");

// OK when no threshold is set, or when the bake `normalized` describes
// (NormalizeParameters' output) measures what the gate judges: an atlas or
// lod-chain product with its quality pass (quality_views > 0). Otherwise
// INVALID_ARGUMENT naming `field` and what the request lacks, so that a gate
// that could never pass is refused before anything is baked.
absl::Status CheckQualityGateApplies(const v1::QualityGate& gate, const v1::BakeParameters& normalized,
                                     const char* field = "gate");

// OK when no threshold is set, or when result.quality() meets every one set
// (silhouette_iou_mean >= min_iou, albedo_psnr_shared_db_mean >= min_psnr_db: colour over the pixels both renders cover, manifest format 2).
// FAILED_PRECONDITION otherwise, giving every measured value against its
// threshold, e.g. "quality gate: silhouette IoU 0.912 < min_iou 0.95; albedo
// PSNR 31.2 dB >= min_psnr_db 30", or "quality gate: the result has no quality
// measurement" when the manifest has none (quality.views == 0).
absl::Status CheckQualityGate(const v1::QualityGate& gate, const v1::Manifest& result);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_REQUEST_QUALITY_GATE_H_
