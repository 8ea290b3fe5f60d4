// The `quality` block and `warnings` list of manifest.json (see
// manifest_format.md) to and from JSON. Internal to manifest_json.cc; kept
// apart so the quality pass's fields live beside each other.
#ifndef IMPOSTOR_COMMON_MANIFEST_QUALITY_MANIFEST_JSON_H_
#define IMPOSTOR_COMMON_MANIFEST_QUALITY_MANIFEST_JSON_H_

#include <nlohmann/json.hpp>

#include "absl/status/status.h"
#include "impostor/v1/types.pb.h"

namespace impostor {

// Adds "quality" (when m.has_quality()) and "warnings" (when non-empty) to
// `j`.
void AddQualityJson(const v1::Manifest& m, nlohmann::json* j);

// Reads `manifest["quality"]` and `manifest["warnings"]` into `m`; both are
// optional (results baked before the quality pass have neither). A present
// quality block must have every field with the right type: INVALID_ARGUMENT
// naming it ("manifest.json: quality.views: missing").
absl::Status ReadQualityJson(const nlohmann::json& manifest, v1::Manifest* m);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_MANIFEST_QUALITY_MANIFEST_JSON_H_
