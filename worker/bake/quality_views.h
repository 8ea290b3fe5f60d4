// Every held-out view of the quality pass as files, so anyone can recompute
// every figure (issue 17): view_NN_mesh.png and view_NN_impostor.png (RGBA8,
// sRGB albedo, straight alpha; alpha = coverage: the fraction of the mesh
// view's supersamples, 0 or 255 for the impostor; covered iff >= 128) and views.json
// with each view's camera (direction, up, right; orthographic, framed by the
// bounding sphere: centre and radius in scene units, as every bake camera,
// common/atlas/frame_camera.h) and the figures measured on it
// (common/quality/image_metrics.h). normal/depth figures come from the
// 16-bit maps, which are not written; every other figure is reproduced
// from the PNGs by CompareViews.
#ifndef IMPOSTOR_WORKER_BAKE_QUALITY_VIEWS_H_
#define IMPOSTOR_WORKER_BAKE_QUALITY_VIEWS_H_

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "absl/status/statusor.h"
#include "common/atlas/frame_camera.h"
#include "common/quality/image_metrics.h"

namespace impostor {

inline constexpr char kQualityViewsFile[] = "views.json";
inline constexpr char kQualityViewsSemantic[] = "quality_views";
inline constexpr char kQualityViewMeshSemantic[] = "quality_view_mesh";
inline constexpr char kQualityViewImpostorSemantic[] = "quality_view_impostor";

struct QualityViewImage {
  std::span<const uint8_t> mesh;      // view_pixels^2 RGBA8
  std::span<const uint8_t> impostor;  // same
};

struct QualityViewsFile {
  std::string file;
  std::string semantic;
  int width = 0, height = 0;  // 0 for views.json
};

// "view_07_mesh.png" (two digits up to 99 views, three beyond).
std::string QualityViewFileName(int index, int count, bool mesh);

// Writes the files into `dir`; returns them in order (PNG pairs, then
// views.json). `mesh_supersampling`: the factor the mesh views were rendered
// at and filtered down by (views.json says so).
absl::StatusOr<std::vector<QualityViewsFile>> WriteQualityViews(
    const std::filesystem::path& dir, const BoundingSphere& sphere, std::string_view reconstruction,
    std::string_view blend, int view_pixels, int mesh_supersampling, const std::vector<glm::vec3>& directions,
    const std::vector<QualityViewImage>& images, const std::vector<ViewMetrics>& metrics);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_BAKE_QUALITY_VIEWS_H_
