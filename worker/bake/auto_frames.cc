#include "worker/bake/auto_frames.h"

#include <algorithm>
#include <filesystem>
#include <optional>
#include <string>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "common/request/auto_frames_ladder.h"
#include "common/request/bake_request.h"
#include "common/manifest/manifest_json.h"
#include "common/request/quality_gate.h"
#include "worker/bake/bake_outputs.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

std::string Describe(const v1::QualityGate& target) {
  std::string s;
  if (target.has_min_iou()) absl::StrAppend(&s, absl::StrFormat("min_iou %g", target.min_iou()));
  if (target.has_min_psnr_db()) {
    absl::StrAppend(&s, s.empty() ? "" : ", ", absl::StrFormat("min_psnr_db %g", target.min_psnr_db()));
  }
  return s;
}

}  // namespace

bool MeetsQualityTarget(const v1::QualityGate& target, const v1::AtlasQuality& quality) {
  v1::Manifest m;
  *m.mutable_quality() = quality;
  return CheckQualityGate(target, m).ok();
}

absl::StatusOr<AtlasBakeOutput> BakeAtlasAutoFrames(const AtlasBakeRequest& request, AtlasRenderer& renderer,
                                                    const BakeProgress& progress, const std::atomic<bool>& cancelled) {
  const v1::BakeParameters& p = request.parameters;
  if (!p.frames_auto() || p.frames() != 0 || !HasQualityGate(p.auto_target()) ||
      (p.has_quality_views() && p.quality_views() == 0)) {
    return absl::InvalidArgumentError(
        "parameters.frames_auto: needs frames unset, auto_target with a threshold and quality_views > 0");
  }
  const std::vector<AutoFramesCandidate> ladder = AutoFramesLadder(p.layout(), p.resolution());
  if (ladder.empty()) {
    return absl::InvalidArgumentError(absl::StrCat("parameters.resolution: ", p.resolution(),
                                                   " px fits no frames_auto count of this layout (",
                                                   AutoFramesLadderText(p.layout()), ")"));
  }
  std::vector<uint32_t> tried;
  std::vector<bool> met;
  std::optional<AtlasBakeOutput> kept;
  fs::path kept_dir;
  double seconds = 0;
  for (size_t i = 0; i < ladder.size(); ++i) {
    if (cancelled) return absl::CancelledError("cancelled between frame counts");
    AtlasBakeRequest candidate = request;
    candidate.parameters.set_frames(ladder[i].frames);
    if (ladder[i].ring_views != 0) candidate.parameters.set_ring_views(ladder[i].ring_views);
    candidate.parameters.set_frames_auto(false);
    candidate.parameters.clear_auto_target();
    candidate.output_dir = request.output_dir / absl::StrCat("frames_auto_", ladder[i].count);
    std::error_code ec;
    fs::remove_all(candidate.output_dir, ec);
    fs::create_directories(candidate.output_dir, ec);
    if (ec) return absl::InternalError(absl::StrCat("cannot create ", candidate.output_dir.string(), ": ", ec.message()));
    // Each candidate gets an equal slice of the progress bar; the ladder
    // usually stops early, so the bar may jump at the end.
    const double lo = static_cast<double>(i) / ladder.size(), hi = static_cast<double>(i + 1) / ladder.size();
    auto out = BakeAtlas(candidate, renderer, [&](std::string_view stage, double f) {
      progress(stage, std::min(0.95, lo + f * (hi - lo)));
    }, cancelled);
    if (!out.ok()) return out.status();
    seconds += out->manifest.timings().total_seconds();
    const bool ok = MeetsQualityTarget(p.auto_target(), out->manifest.quality());
    tried.push_back(ladder[i].count);
    met.push_back(ok);
    spdlog::info("event=frames_auto_candidate cache_key={} count={} frames={} iou_mean={:.4f} psnr_db_mean={:.2f} met={}",
                 request.cache_key, ladder[i].count, ladder[i].frames, out->manifest.quality().silhouette_iou_mean(),
                 out->manifest.quality().albedo_psnr_union_db_mean(), ok);
    if (kept.has_value()) fs::remove_all(kept_dir, ec);
    kept = std::move(*out);
    kept_dir = candidate.output_dir;
    if (ok) break;
  }
  if (!kept.has_value()) return absl::InternalError("frames_auto: empty ladder");

  // The kept candidate's files move up into the output directory; the
  // manifest gains the ladder's report and is written again.
  v1::Manifest manifest = std::move(kept->manifest);
  for (const v1::MapFile& map : manifest.maps()) {
    std::error_code ec;
    fs::rename(kept_dir / map.file(), request.output_dir / map.file(), ec);
    if (ec) return absl::InternalError(absl::StrCat("cannot move ", map.file(), " out of ", kept_dir.string(), ": ", ec.message()));
  }
  std::error_code ec;
  fs::remove_all(kept_dir, ec);
  v1::AtlasQuality* q = manifest.mutable_quality();
  for (size_t i = 0; i < tried.size(); ++i) {
    q->add_frames_tried(tried[i]);
    q->add_frames_met(met[i]);
  }
  if (!met.back()) {
    manifest.add_warnings(absl::StrCat("frames_auto: no frame count tried (", tried.front(), "..", tried.back(),
                                       ") met the target (", Describe(p.auto_target()), "); kept the largest, ",
                                       tried.back()));
  }
  manifest.mutable_timings()->set_total_seconds(seconds);
  manifest.clear_manifest_json();
  AtlasBakeOutput out;
  out.manifest_path = request.output_dir / "manifest.json";
  auto digest = WriteFileWithDigest(out.manifest_path, ManifestToJson(manifest));
  if (!digest.ok()) return digest.status();
  *manifest.mutable_manifest_json() = *digest;
  out.manifest = std::move(manifest);
  spdlog::info("event=frames_auto_done cache_key={} tried={} chosen={} met={} seconds={:.2f}", request.cache_key,
               tried.size(), out.manifest.frames(), met.back(), seconds);
  return out;
}

}  // namespace impostor
