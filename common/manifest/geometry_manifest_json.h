// manifest.json's `bounding_box` and `cutout` blocks (common/
// manifest_format.md), kept apart from manifest_json.cc so each block has
// one owner. Pure functions.
#ifndef IMPOSTOR_COMMON_MANIFEST_GEOMETRY_MANIFEST_JSON_H_
#define IMPOSTOR_COMMON_MANIFEST_GEOMETRY_MANIFEST_JSON_H_

#include <nlohmann/json.hpp>

#include "absl/status/status.h"
#include "impostor/v1/types.pb.h"

namespace impostor {

// Adds the blocks the manifest has (bounding_box when it has 3 + 3 numbers,
// cutout when it has vertices).
void AddGeometryJson(const v1::Manifest& m, nlohmann::json* j);

// Reads them back; both are optional (manifests written before they
// existed). INVALID_ARGUMENT naming the key for a malformed block.
absl::Status ReadGeometryJson(const nlohmann::json& manifest, v1::Manifest* m);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_MANIFEST_GEOMETRY_MANIFEST_JSON_H_
