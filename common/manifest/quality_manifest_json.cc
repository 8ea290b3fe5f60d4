#include "common/manifest/quality_manifest_json.h"

#include <string>
#include <vector>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

using nlohmann::json;

json ReconstructionQualityJson(const v1::ReconstructionQuality& r) {
  return {
      {"reconstruction", r.reconstruction()},
      {"silhouette_iou_min", r.silhouette_iou_min()},
      {"silhouette_iou_mean", r.silhouette_iou_mean()},
      {"albedo_psnr_shared_db_min", r.albedo_psnr_shared_db_min()},
      {"albedo_psnr_shared_db_mean", r.albedo_psnr_shared_db_mean()},
      {"albedo_ssim_shared_min", r.albedo_ssim_shared_min()},
      {"albedo_ssim_shared_mean", r.albedo_ssim_shared_mean()},
      {"boundary_error_px_mean", r.boundary_error_px_mean()},
      {"boundary_error_px_max", r.boundary_error_px_max()},
      {"normal_error_deg_mean", r.normal_error_deg_mean()},
      {"depth_error_mean", r.depth_error_mean()},
      {"pop", r.pop()},
      {"albedo_psnr_union_db_mean", r.albedo_psnr_union_db_mean()},
  };
}

// Reads the figures of json object `o` present in it (absent = 0).
void ReadReconstructionQuality(const json& o, v1::ReconstructionQuality* r) {
  auto num = [&](const char* key) {
    auto f = o.find(key);
    return f != o.end() && f->is_number() ? f->get<float>() : 0.0f;
  };
  if (auto f = o.find("reconstruction"); f != o.end() && f->is_string()) r->set_reconstruction(f->get<std::string>());
  r->set_silhouette_iou_min(num("silhouette_iou_min"));
  r->set_silhouette_iou_mean(num("silhouette_iou_mean"));
  r->set_albedo_psnr_shared_db_min(num("albedo_psnr_shared_db_min"));
  r->set_albedo_psnr_shared_db_mean(num("albedo_psnr_shared_db_mean"));
  r->set_albedo_ssim_shared_min(num("albedo_ssim_shared_min"));
  r->set_albedo_ssim_shared_mean(num("albedo_ssim_shared_mean"));
  r->set_boundary_error_px_mean(num("boundary_error_px_mean"));
  r->set_boundary_error_px_max(num("boundary_error_px_max"));
  r->set_normal_error_deg_mean(num("normal_error_deg_mean"));
  r->set_depth_error_mean(num("depth_error_mean"));
  r->set_pop(num("pop"));
  r->set_albedo_psnr_union_db_mean(num("albedo_psnr_union_db_mean"));
}

// The issue-43 figures, optional: pop_antialiased, sizes, good_up_to_pixels.
absl::Status ReadSizesJson(const json& q, v1::AtlasQuality* out) {
  if (auto f = q.find("pop_antialiased"); f != q.end()) {
    if (!f->is_number()) return absl::InvalidArgumentError("manifest.json: quality.pop_antialiased: not a number");
    out->set_pop_antialiased(f->get<float>());
  }
  auto it = q.find("sizes");
  if (it == q.end()) return absl::OkStatus();
  if (!it->is_array()) return absl::InvalidArgumentError("manifest.json: quality.sizes: not a list");
  for (size_t i = 0; i < it->size(); ++i) {
    const json& s = (*it)[i];
    const auto field = [&](const char* key) { return absl::StrCat("manifest.json: quality.sizes[", i, "].", key); };
    if (!s.is_object())
      return absl::InvalidArgumentError(absl::StrCat("manifest.json: quality.sizes[", i, "]: not an object"));
    v1::SizeQuality* out_size = out->add_sizes();
    for (const char* key : {"pixels", "silhouette_iou_mean", "albedo_psnr_shared_db_mean"}) {
      auto f = s.find(key);
      if (f == s.end() || !f->is_number()) return absl::InvalidArgumentError(field(key) + ": missing or not a number");
    }
    const json& pixels = s["pixels"];
    if (!pixels.is_number_unsigned() || pixels.get<uint64_t>() > 16384) {
      return absl::InvalidArgumentError(field("pixels") + ": not a whole number 0..16384");
    }
    out_size->set_pixels(pixels.get<uint32_t>());
    out_size->set_silhouette_iou_mean(s["silhouette_iou_mean"].get<float>());
    out_size->set_albedo_psnr_shared_db_mean(s["albedo_psnr_shared_db_mean"].get<float>());
    auto meets = s.find("meets");
    if (meets == s.end() || !meets->is_boolean())
      return absl::InvalidArgumentError(field("meets") + ": missing or not true/false");
    out_size->set_meets(meets->get<bool>());
    // Absent from manifests before baker 0.2.0-bake7: 0.
    if (auto firm = s.find("silhouette_iou_firm_mean"); firm != s.end()) {
      if (!firm->is_number() || !(firm->get<double>() >= 0.0 && firm->get<double>() <= 1.0)) {
        return absl::InvalidArgumentError(field("silhouette_iou_firm_mean") + ": not a number 0..1");
      }
      out_size->set_silhouette_iou_firm_mean(firm->get<float>());
    }
  }
  auto good = q.find("good_up_to_pixels");
  if (good == q.end() || !good->is_number_unsigned() || good->get<uint64_t>() > 16384) {
    return absl::InvalidArgumentError(
        "manifest.json: quality.good_up_to_pixels: missing or not a whole number 0..16384");
  }
  out->set_good_up_to_pixels(good->get<uint32_t>());
  return absl::OkStatus();
}

}  // namespace

void AddQualityJson(const v1::Manifest& m, json* j) {
  if (m.has_quality()) {
    const v1::AtlasQuality& q = m.quality();
    (*j)["quality"] = {
        {"blend", q.blend()},
        {"views", q.views()},
        {"view_pixels", q.view_pixels()},
        {"silhouette_iou_min", q.silhouette_iou_min()},
        {"silhouette_iou_mean", q.silhouette_iou_mean()},
        {"albedo_psnr_union_db_min", q.albedo_psnr_union_db_min()},
        {"albedo_psnr_union_db_mean", q.albedo_psnr_union_db_mean()},
        {"albedo_ssim_union_min", q.albedo_ssim_union_min()},
        {"albedo_ssim_union_mean", q.albedo_ssim_union_mean()},
        {"reconstruction", q.reconstruction()},
        {"albedo_psnr_shared_db_min", q.albedo_psnr_shared_db_min()},
        {"albedo_psnr_shared_db_mean", q.albedo_psnr_shared_db_mean()},
        {"albedo_ssim_shared_min", q.albedo_ssim_shared_min()},
        {"albedo_ssim_shared_mean", q.albedo_ssim_shared_mean()},
        {"boundary_error_px_mean", q.boundary_error_px_mean()},
        {"boundary_error_px_max", q.boundary_error_px_max()},
        {"normal_error_deg_mean", q.normal_error_deg_mean()},
        {"normal_error_deg_max", q.normal_error_deg_max()},
        {"depth_error_mean", q.depth_error_mean()},
        {"depth_error_max", q.depth_error_max()},
        {"pop", q.pop()},
        {"frames_tried", std::vector<uint32_t>(q.frames_tried().begin(), q.frames_tried().end())},
        {"frames_met", std::vector<bool>(q.frames_met().begin(), q.frames_met().end())},
        {"worst_view", q.worst_view()},
    };
    // Issue 43; absent from older manifests (read back as 0 and no sizes).
    if (q.pop_antialiased() > 0) (*j)["quality"]["pop_antialiased"] = q.pop_antialiased();
    if (q.sizes_size() > 0) {
      json sizes = json::array();
      for (const v1::SizeQuality& s : q.sizes()) {
        json size = {{"pixels", s.pixels()},
                     {"silhouette_iou_mean", s.silhouette_iou_mean()},
                     {"albedo_psnr_shared_db_mean", s.albedo_psnr_shared_db_mean()},
                     {"meets", s.meets()}};
        if (s.silhouette_iou_firm_mean() > 0) size["silhouette_iou_firm_mean"] = s.silhouette_iou_firm_mean();
        sizes.push_back(std::move(size));
      }
      (*j)["quality"]["sizes"] = std::move(sizes);
      (*j)["quality"]["good_up_to_pixels"] = q.good_up_to_pixels();
    }
    if (q.has_plain()) (*j)["quality"]["plain"] = ReconstructionQualityJson(q.plain());
  }
  if (m.warnings_size() > 0) (*j)["warnings"] = std::vector<std::string>(m.warnings().begin(), m.warnings().end());
}

absl::Status ReadQualityJson(const json& manifest, v1::Manifest* m) {
  if (auto it = manifest.find("warnings"); it != manifest.end()) {
    if (!it->is_array()) return absl::InvalidArgumentError("manifest.json: warnings: not a list");
    for (const json& w : *it) {
      if (!w.is_string()) return absl::InvalidArgumentError("manifest.json: warnings: not a list of strings");
      m->add_warnings(w.get<std::string>());
    }
  }
  auto it = manifest.find("quality");
  if (it == manifest.end()) return absl::OkStatus();
  if (!it->is_object()) return absl::InvalidArgumentError("manifest.json: quality: not an object");
  const json& q = *it;
  std::string error;
  // Reads q[key] as T, or records the first missing/mistyped key.
  auto get = [&]<typename T>(const char* key, T* out) {
    if (!error.empty()) return;
    auto f = q.find(key);
    if (f == q.end()) {
      error = absl::StrCat("manifest.json: quality.", key, ": missing");
      return;
    }
    try {
      *out = f->get<T>();
    } catch (const json::exception&) {
      error = absl::StrCat("manifest.json: quality.", key, ": wrong type");
    }
  };
  std::string blend;
  uint32_t views = 0, view_pixels = 0, worst_view = 0;
  float iou_min = 0, iou_mean = 0, psnr_min = 0, psnr_mean = 0, ssim_min = 0, ssim_mean = 0;
  float normal_mean = 0, normal_max = 0, depth_mean = 0, depth_max = 0, pop = 0;
  std::vector<uint32_t> tried;
  std::vector<bool> met;
  get("blend", &blend);
  get("views", &views);
  get("view_pixels", &view_pixels);
  get("silhouette_iou_min", &iou_min);
  get("silhouette_iou_mean", &iou_mean);
  // Format 1 named the union figures albedo_psnr_db_* / albedo_ssim_*.
  const bool format1 = !q.contains("albedo_psnr_union_db_min");
  get(format1 ? "albedo_psnr_db_min" : "albedo_psnr_union_db_min", &psnr_min);
  get(format1 ? "albedo_psnr_db_mean" : "albedo_psnr_union_db_mean", &psnr_mean);
  get(format1 ? "albedo_ssim_min" : "albedo_ssim_union_min", &ssim_min);
  get(format1 ? "albedo_ssim_mean" : "albedo_ssim_union_mean", &ssim_mean);
  std::string reconstruction;
  float shared_psnr_min = 0, shared_psnr_mean = 0, shared_ssim_min = 0, shared_ssim_mean = 0;
  float boundary_mean = 0, boundary_max = 0;
  if (!format1) {
    get("reconstruction", &reconstruction);
    get("albedo_psnr_shared_db_min", &shared_psnr_min);
    get("albedo_psnr_shared_db_mean", &shared_psnr_mean);
    get("albedo_ssim_shared_min", &shared_ssim_min);
    get("albedo_ssim_shared_mean", &shared_ssim_mean);
    get("boundary_error_px_mean", &boundary_mean);
    get("boundary_error_px_max", &boundary_max);
  }
  get("normal_error_deg_mean", &normal_mean);
  get("normal_error_deg_max", &normal_max);
  get("depth_error_mean", &depth_mean);
  get("depth_error_max", &depth_max);
  get("pop", &pop);
  get("frames_tried", &tried);
  get("frames_met", &met);
  get("worst_view", &worst_view);
  if (!error.empty()) return absl::InvalidArgumentError(error);
  if (tried.size() != met.size()) {
    return absl::InvalidArgumentError("manifest.json: quality.frames_met: not as long as frames_tried");
  }
  v1::AtlasQuality* out = m->mutable_quality();
  out->set_blend(blend);
  out->set_views(views);
  out->set_view_pixels(view_pixels);
  out->set_silhouette_iou_min(iou_min);
  out->set_silhouette_iou_mean(iou_mean);
  out->set_albedo_psnr_union_db_min(psnr_min);
  out->set_albedo_psnr_union_db_mean(psnr_mean);
  out->set_albedo_ssim_union_min(ssim_min);
  out->set_albedo_ssim_union_mean(ssim_mean);
  out->set_normal_error_deg_mean(normal_mean);
  out->set_normal_error_deg_max(normal_max);
  out->set_depth_error_mean(depth_mean);
  out->set_depth_error_max(depth_max);
  out->set_pop(pop);
  out->set_reconstruction(reconstruction);
  out->set_albedo_psnr_shared_db_min(shared_psnr_min);
  out->set_albedo_psnr_shared_db_mean(shared_psnr_mean);
  out->set_albedo_ssim_shared_min(shared_ssim_min);
  out->set_albedo_ssim_shared_mean(shared_ssim_mean);
  out->set_boundary_error_px_mean(boundary_mean);
  out->set_boundary_error_px_max(boundary_max);
  if (auto p = q.find("plain"); p != q.end()) {
    if (!p->is_object()) return absl::InvalidArgumentError("manifest.json: quality.plain: not an object");
    ReadReconstructionQuality(*p, out->mutable_plain());
  }
  for (uint32_t f : tried) out->add_frames_tried(f);
  for (bool b : met) out->add_frames_met(b);
  out->set_worst_view(worst_view);
  return ReadSizesJson(q, out);
}

}  // namespace impostor
