// Renders each card's own triangles orthographically onto its plane into
// the shared card atlas, with the atlas renderer's three maps, then dilates
// every card into its gutter.
//
// Each card is one AtlasRenderer::Render call over a Scene holding only that
// card's triangles (materials made double-sided, since the card is drawn
// from both sides), seen along the card's normal with camera up = the card's
// v axis and right = its u axis. The renderer's view is a square of a
// bounding sphere's diameter, so each card gets a square scratch target
// whose top-left corner holds exactly the card's tile (the "sphere" is
// placed so that the card's (-u, +v) corner lands on pixel (0, 0) and one
// texel is 1 / texels_per_unit), deep enough (sphere radius >= the card's
// farthest triangle) that no assigned triangle is clipped; the tile is then
// copied into the atlas. The renderer's API and FrameCamera stay as they are.
//
// Card atlas encodings (as the impostor atlas, worker/gpu/atlas_renderer.h),
// except the depth channel of normal_depth: A = (1 - dist / radius) / 2 with
// dist the signed distance from the card's plane along its normal and radius
// the mesh's bounding-sphere radius: 0.5 on the plane.
//
// Thread-safety: one capture per AtlasRenderer at a time.
#ifndef IMPOSTOR_WORKER_CARDS_CARD_CAPTURE_H_
#define IMPOSTOR_WORKER_CARDS_CARD_CAPTURE_H_

#include <atomic>
#include <cstdint>
#include <functional>
#include <vector>

#include "absl/status/statusor.h"
#include "worker/cards/card_packing.h"
#include "worker/cards/card_rect.h"
#include "worker/gpu/atlas_renderer.h"
#include "worker/scene/scene.h"

namespace impostor {

struct CardCaptureRequest {
  const Scene* scene = nullptr;
  BoundingSphere mesh_sphere;               // depth encoding
  std::vector<CardRect> cards;              // snapped to their tiles
  std::vector<std::vector<uint32_t>> card_triangles;  // per card, triangle indices into scene
  std::vector<float> card_depth;            // per card, farthest assigned vertex from the plane
  CardPacking packing;
  int atlas_size = 0;
};

struct CardCapture {
  AtlasImages atlas;                  // dilated
  std::vector<uint64_t> card_texels;  // covered texels per card
  RenderTimings timings;              // summed over cards
};

// Scratch targets larger than this are capped (a card whose triangles lie
// farther from its plane than the atlas is wide loses the farthest parts).
inline constexpr int kMaxCardScratchPixels = 8192;

// Renders every card. CANCELLED when `cancelled` turns true between cards;
// `progress` (may be empty) gets the fraction of cards done. The renderer's
// errors otherwise.
absl::StatusOr<CardCapture> CaptureCards(const CardCaptureRequest& request, AtlasRenderer& renderer,
                                         const std::function<void(double)>& progress,
                                         const std::atomic<bool>& cancelled);

// Converts the dilated scene-space normals of each card's tile and gutter
// into a tangent-space normal map for the glTF material (RGBA8: RGB =
// (dot(n, u), dot(n, v), dot(n, normal)) * 0.5 + 0.5 with z kept positive,
// A = 255). Texels outside every card are the flat normal (128, 128, 255).
std::vector<uint8_t> TangentSpaceNormals(const AtlasImages& atlas, const std::vector<CardRect>& cards,
                                         const CardPacking& packing);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_CARDS_CARD_CAPTURE_H_
