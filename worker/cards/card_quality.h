// Judges a card cluster against its mesh: both are rendered by the atlas
// renderer from held-out directions framed by the mesh's bounding sphere,
// and compared with the image metrics of common/quality/image_metrics.h
// (silhouette IoU, albedo PSNR over the union of both silhouettes).
//
// Held-out directions come from a fixed-seed generator (uniform on the
// sphere) and skip any within 10 degrees of a card's normal, where a card
// faces the camera and looks its best; they are the same for every bake of
// the same cards.
//
// Thread-safety: one call per AtlasRenderer at a time.
#ifndef IMPOSTOR_WORKER_CARDS_CARD_QUALITY_H_
#define IMPOSTOR_WORKER_CARDS_CARD_QUALITY_H_

#include <vector>

#include <glm/vec3.hpp>

#include "absl/status/statusor.h"
#include "worker/gpu/atlas_renderer.h"
#include "worker/scene/scene.h"

namespace impostor {

inline constexpr int kCardQualityViews = 16;
inline constexpr int kCardQualityPixels = 128;

struct CardQualityFigures {
  int views = 0;
  int view_pixels = 0;
  double iou_mean = 0;
  double iou_min = 0;
  double albedo_psnr_db = 0;  // mean over views, dB
};

// `count` unit directions, fixed seed, none within 10 degrees of +-normal
// for any of `card_normals`.
std::vector<glm::vec3> CardHeldOutDirections(int count, const std::vector<glm::vec3>& card_normals);

// Renders `mesh` and `cards` (the .glb loaded back) from `views` held-out
// directions at `view_pixels` square each. The renderer's errors.
absl::StatusOr<CardQualityFigures> JudgeCards(const Scene& mesh, const Scene& cards, const BoundingSphere& sphere,
                                              const std::vector<glm::vec3>& card_normals, AtlasRenderer& renderer,
                                              int views = kCardQualityViews, int view_pixels = kCardQualityPixels);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_CARDS_CARD_QUALITY_H_
