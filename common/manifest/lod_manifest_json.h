// The `lods` list of a PRODUCT_LOD_CHAIN manifest.json (see
// manifest_format.md) to and from JSON. Internal to manifest_json.cc; kept
// apart so the LOD chain's fields live beside each other.
#ifndef IMPOSTOR_COMMON_MANIFEST_LOD_MANIFEST_JSON_H_
#define IMPOSTOR_COMMON_MANIFEST_LOD_MANIFEST_JSON_H_

#include <nlohmann/json.hpp>

#include "absl/status/status.h"
#include "impostor/v1/types.pb.h"

namespace impostor {

// [{"level", "kind", "file", "digest", "triangles", "target_ratio", "error",
//   "threshold", "sloppy"}, ...] in level order.
nlohmann::json LodLevelsToJson(const google::protobuf::RepeatedPtrField<v1::LodLevel>& lods);

// Reads `manifest["lods"]` into m->lods. INVALID_ARGUMENT naming the entry
// and key ("manifest.json: lods[1].threshold: missing") when the list is
// missing or empty, an entry lacks a field, has the wrong type, an unknown
// kind, or levels are not 0, 1, 2... in order.
absl::Status ReadLodLevels(const nlohmann::json& manifest, v1::Manifest* m);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_MANIFEST_LOD_MANIFEST_JSON_H_
