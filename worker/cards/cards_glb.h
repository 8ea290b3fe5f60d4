// Writes a card cluster as a standard glTF 2.0 binary (.glb) that any engine
// or viewer loads without our code: one mesh of one primitive, two
// triangles per card (counter-clockwise seen from the card's normal side),
// POSITION / NORMAL / TANGENT / TEXCOORD_0 into the card atlas, and one
// material: alphaMode MASK, doubleSided, baseColorTexture = the albedo atlas,
// normalTexture = a tangent-space normal atlas, metallicRoughnessTexture and
// occlusionTexture = the ORM atlas (its R, G, B are glTF's occlusion,
// roughness and metalness channels). Images are embedded PNGs.
//
// Tangent frame of every card: TANGENT = (u, +1), so glTF's bitangent
// cross(normal, tangent) * w is the card's v axis, which points up in the
// image (row 0 is the card's +v edge): the "+Y up" convention of glTF normal
// textures.
//
// Pure function; thread-safe.
#ifndef IMPOSTOR_WORKER_CARDS_CARDS_GLB_H_
#define IMPOSTOR_WORKER_CARDS_CARDS_GLB_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "common/atlas/frame_camera.h"
#include "worker/cards/card_rect.h"

namespace impostor {

struct CardsGlbInput {
  std::vector<CardRect> cards;  // as drawn (already snapped to their tiles)
  std::vector<TileRect> tiles;  // per card, its texels in the atlas
  int atlas_size = 0;           // the atlas is atlas_size x atlas_size
  std::string albedo_png;       // PNG bytes, RGBA (sRGB colour, alpha = coverage)
  std::string normal_png;       // PNG bytes, tangent-space normals; empty = no normalTexture
  std::string orm_png;          // PNG bytes, R occlusion, G roughness, B metalness
  float alpha_cutoff = 0.5f;
  std::string generator = "impostor cards baker";
};

// The .glb bytes. INVALID_ARGUMENT when cards and tiles differ in number,
// there are no cards, or a required image is missing.
absl::StatusOr<std::string> EncodeCardsGlb(const CardsGlbInput& input);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_CARDS_CARDS_GLB_H_
