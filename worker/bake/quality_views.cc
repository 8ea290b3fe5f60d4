#include "worker/bake/quality_views.h"

#include <algorithm>
#include <fstream>

#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "common/util/parallel_for.h"
#include "common/runtime/reference_renderer.h"
#include "worker/output/map_writer.h"

namespace impostor {

std::string QualityViewFileName(int index, int count, bool mesh) {
  return absl::StrFormat(count > 100 ? "view_%03d_%s.png" : "view_%02d_%s.png", index, mesh ? "mesh" : "impostor");
}

absl::StatusOr<std::vector<QualityViewsFile>> WriteQualityViews(
    const std::filesystem::path& dir, const BoundingSphere& sphere, std::string_view reconstruction,
    std::string_view blend, int view_pixels, int mesh_supersampling, const std::vector<glm::vec3>& directions,
    const std::vector<QualityViewImage>& images, const std::vector<ViewMetrics>& metrics) {
  if (images.size() != directions.size() || metrics.size() != directions.size()) {
    return absl::InvalidArgumentError("quality views: directions, images and metrics differ in count");
  }
  const int count = static_cast<int>(directions.size());
  // The PNGs on all cores: one after another they were a tenth of the pass
  // once the views were drawn on a GPU (33 files of 256 px: 0.15 s).
  std::vector<absl::Status> written(2 * static_cast<size_t>(count));
  ParallelFor(written.size(), [&](size_t k) {
    const int i = static_cast<int>(k / 2);
    const bool mesh = k % 2 == 0;
    written[k] = WritePngRgba8(dir / QualityViewFileName(i, count, mesh), mesh ? images[i].mesh : images[i].impostor,
                               view_pixels, view_pixels);
  });
  for (const absl::Status& s : written) {
    if (!s.ok()) return s;
  }
  std::vector<QualityViewsFile> files;
  nlohmann::json views = nlohmann::json::array();
  for (int i = 0; i < count; ++i) {
    const std::string mesh = QualityViewFileName(i, count, true), impostor = QualityViewFileName(i, count, false);
    files.push_back({mesh, kQualityViewMeshSemantic, view_pixels, view_pixels});
    files.push_back({impostor, kQualityViewImpostorSemantic, view_pixels, view_pixels});
    const FrameCamera c = ViewCameraFor(directions[i]);
    const ViewMetrics& m = metrics[i];
    views.push_back({
        {"index", i},
        {"direction", {c.direction.x, c.direction.y, c.direction.z}},
        {"up", {c.up.x, c.up.y, c.up.z}},
        {"right", {c.right.x, c.right.y, c.right.z}},
        {"mesh", mesh},
        {"impostor", impostor},
        {"figures",
         {{"silhouette_iou", m.iou},
          {"albedo_psnr_shared_db", m.albedo_psnr_shared_db},
          {"albedo_ssim_shared", m.albedo_ssim_shared},
          {"boundary_error_px_mean", m.boundary_error_px_mean},
          {"boundary_error_px_max", m.boundary_error_px_max},
          {"albedo_psnr_union_db", m.albedo_psnr_db},
          {"albedo_ssim_union", m.albedo_ssim},
          {"normal_error_deg_mean", m.normal_error_deg_mean},
          {"depth_error_mean", m.depth_error_mean}}},
    });
  }
  const nlohmann::json doc = {
      {"reconstruction", reconstruction},
      {"blend", blend},
      {"view_pixels", view_pixels},
      {"mesh_supersampling",
       {{"factor", mesh_supersampling},
        {"note", "each mesh view was rendered factor x factor times larger and box-filtered down: alpha = the "
                 "fraction of its samples the mesh covers (covered iff more than half), colour their mean"}}},
      {"orthographic",
       {{"center", {sphere.center.x, sphere.center.y, sphere.center.z}},
        {"radius", sphere.radius},
        {"note", "each view looks along -direction at center; its square of side 2 radius spans the image, up "
                 "toward row 0, right toward the last column; alpha >= 128 is covered"}}},
      {"views", views},
  };
  std::ofstream out(dir / kQualityViewsFile, std::ios::trunc);
  out << doc.dump(1) << "\n";
  if (!out) return absl::InternalError(absl::StrCat("quality views: cannot write ", (dir / kQualityViewsFile).string()));
  files.push_back({kQualityViewsFile, kQualityViewsSemantic, 0, 0});
  return files;
}

}  // namespace impostor
