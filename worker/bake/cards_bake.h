// The worker's bake pipeline for card clusters ("billboard clouds"), by
// stage: load (glTF -> Scene) -> fit (planes within the tolerance,
// worker/cards/plane_fitting) -> cards (minimal rectangles, worker/cards/
// card_rect; packed at one texel density, card_packing) -> render (each
// card's own triangles onto its plane, card_capture) -> write (the card
// atlas maps, cards.glb, manifest.json) -> judge (cards.glb loaded back and
// rendered against the mesh from held-out views, card_quality).
// Like BakeAtlas it knows nothing of gRPC; the worker loop uploads every file
// the manifest's `maps` list (cards.glb among them), plus manifest.json.
//
// Thread-safety: one bake per AtlasRenderer at a time.
#ifndef IMPOSTOR_WORKER_BAKE_CARDS_BAKE_H_
#define IMPOSTOR_WORKER_BAKE_CARDS_BAKE_H_

#include <atomic>

#include "absl/status/statusor.h"
#include "impostor/v1/types.pb.h"
#include "worker/bake/atlas_bake.h"
#include "worker/gpu/atlas_renderer.h"

namespace impostor {

// File names in the result directory.
inline constexpr char kCardsGlbFile[] = "cards.glb";
inline constexpr char kCardNormalTangentFile[] = "normal_tangent.png";

// The whole pipeline for a request whose parameters have product
// PRODUCT_CARDS (normalised: max_planes, tolerance and resolution set):
// writes albedo_alpha.png, normal_depth.png, orm.png, normal_tangent.png,
// cards.glb and manifest.json into request.output_dir. INVALID_ARGUMENT for
// a mesh that cannot be baked (the loader's message, or no extent);
// CANCELLED when `cancelled` turns true between stages; INTERNAL when a file
// cannot be written; the renderer's errors otherwise.
absl::StatusOr<AtlasBakeOutput> BakeCards(const AtlasBakeRequest& request, AtlasRenderer& renderer,
                                          const BakeProgress& progress, const std::atomic<bool>& cancelled);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_BAKE_CARDS_BAKE_H_
