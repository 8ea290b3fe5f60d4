#include "common/manifest/lod_manifest_json.h"

#include <string>

#include "absl/strings/str_cat.h"

namespace impostor {

using nlohmann::json;

json LodLevelsToJson(const google::protobuf::RepeatedPtrField<v1::LodLevel>& lods) {
  json out = json::array();
  for (const v1::LodLevel& l : lods) {
    out.push_back({{"level", l.level()},
                   {"kind", l.kind()},
                   {"file", l.file()},
                   {"digest", {{"hash", l.digest().hash()}, {"size_bytes", l.digest().size_bytes()}}},
                   {"triangles", l.triangles()},
                   {"target_ratio", l.target_ratio()},
                   {"error", l.error()},
                   {"threshold", l.threshold()},
                   {"sloppy", l.sloppy()}});
  }
  return out;
}

absl::Status ReadLodLevels(const json& manifest, v1::Manifest* m) {
  auto it = manifest.find("lods");
  if (it == manifest.end() || !it->is_array() || it->empty()) {
    return absl::InvalidArgumentError("manifest.json: lods: missing or empty for product lod-chain");
  }
  for (size_t i = 0; i < it->size(); ++i) {
    const json& e = (*it)[i];
    const std::string path = absl::StrCat("manifest.json: lods[", i, "].");
    if (!e.is_object()) return absl::InvalidArgumentError(path + " not an object");
    std::string key;
    try {
      v1::LodLevel l;
      key = "level";
      l.set_level(e.at(key).get<uint32_t>());
      key = "kind";
      l.set_kind(e.at(key).get<std::string>());
      key = "file";
      l.set_file(e.at(key).get<std::string>());
      key = "digest";
      l.mutable_digest()->set_hash(e.at(key).at("hash").get<std::string>());
      l.mutable_digest()->set_size_bytes(e.at(key).at("size_bytes").get<int64_t>());
      key = "triangles";
      l.set_triangles(e.at(key).get<uint64_t>());
      key = "target_ratio";
      l.set_target_ratio(e.at(key).get<float>());
      key = "error";
      l.set_error(e.at(key).get<float>());
      key = "threshold";
      l.set_threshold(e.at(key).get<float>());
      key = "sloppy";
      l.set_sloppy(e.value("sloppy", false));
      if (l.level() != i) {
        return absl::InvalidArgumentError(absl::StrCat(path, "level: ", l.level(), " out of order (expected ", i, ")"));
      }
      if (l.kind() != "mesh" && l.kind() != "impostor") {
        return absl::InvalidArgumentError(absl::StrCat(path, "kind: unknown \"", l.kind(), "\""));
      }
      *m->add_lods() = std::move(l);
    } catch (const json::exception&) {
      return absl::InvalidArgumentError(absl::StrCat(path, key, ": missing or wrong type"));
    }
  }
  return absl::OkStatus();
}

}  // namespace impostor
