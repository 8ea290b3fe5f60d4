#include "client/transport/job_convert.h"

#include <string>

#include "absl/strings/str_cat.h"

namespace impostor::sdk {

std::string_view JobStateName(JobState state) {
  switch (state) {
    case JobState::kQueued: return "queued";
    case JobState::kRunning: return "running";
    case JobState::kSucceeded: return "succeeded";
    case JobState::kFailed: return "failed";
    case JobState::kCancelled: return "cancelled";
    case JobState::kUnknown: break;
  }
  return "unknown";
}

bool IsTerminal(JobState state) {
  return state == JobState::kSucceeded || state == JobState::kFailed || state == JobState::kCancelled;
}

JobState ToJobState(v1::JobState state) {
  switch (state) {
    case v1::JOB_STATE_QUEUED: return JobState::kQueued;
    case v1::JOB_STATE_RUNNING: return JobState::kRunning;
    case v1::JOB_STATE_SUCCEEDED: return JobState::kSucceeded;
    case v1::JOB_STATE_FAILED: return JobState::kFailed;
    case v1::JOB_STATE_CANCELLED: return JobState::kCancelled;
    default: return JobState::kUnknown;
  }
}

JobUpdate ToJobUpdate(const v1::Job& job) {
  JobUpdate u;
  u.job_id = job.job_id();
  u.cache_key = job.cache_key();
  u.state = ToJobState(job.state());
  u.progress = job.progress();
  u.stage = job.stage();
  if (job.has_error()) {
    u.error_code = job.error().code();
    u.error_message = job.error().message();
  }
  u.cached = job.cached();
  return u;
}

absl::StatusOr<v1::BakeParameters> ToBakeParameters(const BakeSettings& settings) {
  v1::BakeParameters p;
  if (settings.layout.empty()) {
    p.set_layout(v1::LAYOUT_UNSPECIFIED);  // the server's default
  } else if (settings.layout == "octahedral") {
    p.set_layout(v1::LAYOUT_OCTAHEDRAL);
  } else if (settings.layout == "hemi-octahedral") {
    p.set_layout(v1::LAYOUT_HEMI_OCTAHEDRAL);
  } else if (settings.layout == "azimuth-elevation") {
    p.set_layout(v1::LAYOUT_AZIMUTH_ELEVATION);
  } else if (settings.layout == "ring-top") {
    p.set_layout(v1::LAYOUT_RING_TOP);
  } else if (settings.layout == "billboard") {
    p.set_layout(v1::LAYOUT_BILLBOARD);
  } else {
    return absl::InvalidArgumentError(
        absl::StrCat("layout: unknown layout \"", settings.layout,
                     "\"; expected octahedral, hemi-octahedral, azimuth-elevation, ring-top or billboard"));
  }
  if (settings.ring_views.has_value()) p.set_ring_views(*settings.ring_views);
  if (settings.supersampling.has_value()) p.set_supersampling(*settings.supersampling);
  p.set_frames(settings.frames);
  p.set_resolution(settings.resolution);
  if (settings.product.empty() || settings.product == "atlas") {
    // PRODUCT_UNSPECIFIED: the server's default, the atlas.
  } else if (settings.product == "surfels") {
    p.set_product(v1::PRODUCT_SURFELS);
  } else if (settings.product == "lod-chain") {
    p.set_product(v1::PRODUCT_LOD_CHAIN);
  } else if (settings.product == "cards") {
    p.set_product(v1::PRODUCT_CARDS);
  } else {
    return absl::InvalidArgumentError(
        absl::StrCat("product: unknown product \"", settings.product, "\"; expected \"atlas\" or \"surfels\""));
  }
  // Preset and budget go to the server as given: it owns their meaning and
  // refuses them with product atlas.
  p.set_preset(settings.preset);
  if (settings.point_budget.has_value()) p.set_point_budget(*settings.point_budget);
  for (float r : settings.lod_ratios) p.add_lod_ratios(r);
  if (settings.lod_pixel_error.has_value()) p.set_lod_pixel_error(*settings.lod_pixel_error);
  if (settings.max_planes.has_value()) p.set_max_planes(*settings.max_planes);
  if (settings.tolerance.has_value()) p.set_tolerance(*settings.tolerance);
  if (settings.quality_views.has_value()) p.set_quality_views(*settings.quality_views);
  p.set_emissive(settings.emissive);
  p.set_texture_array(settings.texture_array);
  if (settings.texture_format == "png") {
    p.set_texture_format(v1::TEXTURE_FORMAT_PNG);
  } else if (settings.texture_format == "ktx2") {
    p.set_texture_format(v1::TEXTURE_FORMAT_KTX2);
  } else if (!settings.texture_format.empty()) {
    return absl::InvalidArgumentError(absl::StrCat("texture_format: unknown format \"", settings.texture_format,
                                                   "\"; expected png or ktx2"));
  }
  if (settings.albedo_codec == "uastc") {
    p.set_albedo_codec(v1::ALBEDO_CODEC_UASTC);
  } else if (settings.albedo_codec == "uastc-rdo") {
    p.set_albedo_codec(v1::ALBEDO_CODEC_UASTC_RDO);
  } else if (!settings.albedo_codec.empty()) {
    return absl::InvalidArgumentError(absl::StrCat("albedo_codec: unknown codec \"", settings.albedo_codec,
                                                   "\"; expected uastc or uastc-rdo"));
  }
  // frames_auto's target is the request's gate: one pair of thresholds.
  if (settings.frames_auto) {
    p.set_frames_auto(true);
    if (settings.min_iou.has_value()) p.mutable_auto_target()->set_min_iou(*settings.min_iou);
    if (settings.min_psnr_db.has_value()) p.mutable_auto_target()->set_min_psnr_db(*settings.min_psnr_db);
  }
  return p;
}

void ApplySchedulingSettings(const BakeSettings& settings, v1::SubmitBakeRequest* request) {
  request->set_priority(settings.priority);
  for (const std::string& tag : settings.required_tags) request->add_required_tags(tag);
  if (settings.min_iou.has_value()) request->mutable_gate()->set_min_iou(*settings.min_iou);
  if (settings.min_psnr_db.has_value()) request->mutable_gate()->set_min_psnr_db(*settings.min_psnr_db);
}

}  // namespace impostor::sdk
