// The `cards` block of a PRODUCT_CARDS manifest.json (see
// manifest_format.md) to and from JSON. Internal to manifest_json.cc; kept
// apart so the card cluster's fields live beside each other.
#ifndef IMPOSTOR_COMMON_MANIFEST_CARDS_MANIFEST_JSON_H_
#define IMPOSTOR_COMMON_MANIFEST_CARDS_MANIFEST_JSON_H_

#include <nlohmann/json.hpp>

#include "absl/status/status.h"
#include "impostor/v1/types.pb.h"

namespace impostor {

// {"file", "digest", "tolerance", "max_distance", "mean_distance",
//  "budget_exhausted", "triangles", "planes": [[nx, ny, nz, d], ...],
//  "triangle_plane": [...], "cards": [{"corners", "triangles", "texels",
//  "tile", "max_distance", "mean_distance"}, ...], "quality": {...}}
nlohmann::json CardsToJson(const v1::CardCluster& cards);

// Reads `manifest["cards"]` into m->cards. INVALID_ARGUMENT naming the key
// ("manifest.json: cards.planes[2]: expected [nx, ny, nz, d]") when the
// block or a field is missing, has the wrong type or shape, or a
// triangle_plane entry names no plane. `quality` is optional.
absl::Status ReadCards(const nlohmann::json& manifest, v1::Manifest* m);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_MANIFEST_CARDS_MANIFEST_JSON_H_
