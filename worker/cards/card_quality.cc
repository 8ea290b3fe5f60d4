#include "worker/cards/card_quality.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <glm/geometric.hpp>

#include "common/quality/image_metrics.h"

namespace impostor {
namespace {

constexpr uint32_t kSeed = 20030727;  // fixed: the same views for every bake
constexpr float kCos10Degrees = 0.98480775f;

// One tile of an atlas, copied into its own image.
template <typename T>
std::vector<T> CropTile(const std::vector<T>& image, int atlas_size, const TileRect& t) {
  std::vector<T> out(static_cast<size_t>(t.width) * t.height * 4);
  for (int y = 0; y < t.height; ++y) {
    std::copy_n(image.begin() + (static_cast<size_t>(t.y + y) * atlas_size + t.x) * 4, t.width * 4,
                out.begin() + static_cast<size_t>(y) * t.width * 4);
  }
  return out;
}

}  // namespace

std::vector<glm::vec3> CardHeldOutDirections(int count, const std::vector<glm::vec3>& card_normals) {
  std::mt19937 rng(kSeed);
  std::normal_distribution<float> gauss(0.0f, 1.0f);
  std::vector<glm::vec3> out;
  for (int tries = 0; static_cast<int>(out.size()) < count && tries < 100000; ++tries) {
    glm::vec3 d(gauss(rng), gauss(rng), gauss(rng));
    const float len = glm::length(d);
    if (!(len > 1e-6f)) continue;
    d /= len;
    bool facing_a_card = false;
    for (const glm::vec3& n : card_normals) facing_a_card |= std::abs(glm::dot(d, n)) > kCos10Degrees;
    if (!facing_a_card) out.push_back(d);
  }
  return out;
}

absl::StatusOr<CardQualityFigures> JudgeCards(const Scene& mesh, const Scene& cards, const BoundingSphere& sphere,
                                              const std::vector<glm::vec3>& card_normals, AtlasRenderer& renderer,
                                              int views, int view_pixels) {
  CardQualityFigures q;
  const std::vector<glm::vec3> dirs = CardHeldOutDirections(views, card_normals);
  q.views = static_cast<int>(dirs.size());
  q.view_pixels = view_pixels;
  if (dirs.empty()) return q;
  const int grid = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(dirs.size()))));
  std::vector<FrameCamera> cameras;
  for (size_t i = 0; i < dirs.size(); ++i) {
    FrameCamera c;
    c.index = static_cast<int>(i);
    c.direction = dirs[i];
    c.up = CameraUpFor(c.direction);
    c.right = glm::normalize(glm::cross(c.up, c.direction));
    c.tile = {static_cast<int>(i % grid) * view_pixels, static_cast<int>(i / grid) * view_pixels, view_pixels,
              view_pixels};
    cameras.push_back(c);
  }
  const int size = grid * view_pixels;
  auto reference = renderer.Render(mesh, sphere, cameras, size, {}, nullptr);
  if (!reference.ok()) return reference.status();
  auto test = renderer.Render(cards, sphere, cameras, size, {}, nullptr);
  if (!test.ok()) return test.status();
  double iou_sum = 0, psnr_sum = 0;
  q.iou_min = 1.0;
  for (const FrameCamera& c : cameras) {
    const std::vector<uint8_t> a = CropTile(reference->albedo_alpha, size, c.tile);
    const std::vector<uint8_t> b = CropTile(test->albedo_alpha, size, c.tile);
    const ViewPixels ref{view_pixels, view_pixels, a, {}};
    const ViewPixels tst{view_pixels, view_pixels, b, {}};
    const double iou = SilhouetteIou(ref, tst);
    iou_sum += iou;
    q.iou_min = std::min(q.iou_min, iou);
    psnr_sum += AlbedoPsnrDb(ref, tst);
  }
  q.iou_mean = iou_sum / static_cast<double>(cameras.size());
  q.albedo_psnr_db = psnr_sum / static_cast<double>(cameras.size());
  return q;
}

}  // namespace impostor
