// LoadLodChain: reads the `lods` list of a lod-chain manifest.json
// (common/manifest/manifest_format.md) with nlohmann::json directly, so a game links
// neither protobuf nor gRPC for it.
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "impostor/lod.h"

namespace impostor::sdk {

absl::StatusOr<LodChain> LoadLodChain(const std::filesystem::path& manifest_json) {
  std::ifstream in(manifest_json, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat("cannot open '", manifest_json.string(), "'"));
  std::stringstream text;
  text << in.rdbuf();
  const nlohmann::json j = nlohmann::json::parse(text.str(), nullptr, /*allow_exceptions=*/false);
  const std::string name = manifest_json.filename().string();
  if (j.is_discarded() || !j.is_object()) return absl::InvalidArgumentError(name + ": not a JSON object");
  if (j.value("product", std::string()) != "lod-chain") {
    return absl::InvalidArgumentError(absl::StrCat(name, ": product: \"", j.value("product", std::string()),
                                                   "\" is not \"lod-chain\""));
  }
  LodChain chain;
  chain.directory = manifest_json.parent_path();
  std::string key;
  try {
    key = "bounding_sphere";
    const auto& sphere = j.at(key);
    const auto center = sphere.at("center").get<std::vector<float>>();
    if (center.size() != 3) return absl::InvalidArgumentError(name + ": bounding_sphere.center: expected 3 numbers");
    chain.center = {center[0], center[1], center[2]};
    chain.radius = sphere.at("radius").get<float>();
    key = "lods";
    const auto& lods = j.at(key);
    if (!lods.is_array() || lods.empty()) return absl::InvalidArgumentError(name + ": lods: missing or empty");
    for (size_t i = 0; i < lods.size(); ++i) {
      key = absl::StrCat("lods[", i, "]");
      const auto& e = lods[i];
      LodLevelInfo l;
      l.level = e.at("level").get<int>();
      const std::string kind = e.at("kind").get<std::string>();
      if (kind != "mesh" && kind != "impostor") {
        return absl::InvalidArgumentError(absl::StrCat(name, ": ", key, ".kind: unknown \"", kind, "\""));
      }
      l.kind = kind == "mesh" ? LodLevelInfo::Kind::kMesh : LodLevelInfo::Kind::kImpostor;
      l.file = e.at("file").get<std::string>();
      l.digest_hash = e.at("digest").at("hash").get<std::string>();
      l.size_bytes = e.at("digest").at("size_bytes").get<int64_t>();
      l.triangles = e.at("triangles").get<uint64_t>();
      l.target_ratio = e.at("target_ratio").get<float>();
      l.error = e.at("error").get<float>();
      l.threshold = e.at("threshold").get<float>();
      l.sloppy = e.value("sloppy", false);
      if (l.level != static_cast<int>(i)) {
        return absl::InvalidArgumentError(
            absl::StrCat(name, ": ", key, ".level: ", l.level, " out of order (expected ", i, ")"));
      }
      if (l.file.empty() || l.file.find('/') != std::string::npos || l.file == "." || l.file == "..") {
        return absl::InvalidArgumentError(absl::StrCat(name, ": ", key, ".file: \"", l.file,
                                                       "\" is not a plain file name"));
      }
      if (!(l.threshold >= 0.0f) || (i > 0 && l.threshold > chain.levels.back().threshold)) {
        return absl::InvalidArgumentError(absl::StrCat(name, ": ", key, ".threshold: ", l.threshold,
                                                       " is negative or larger than the previous level's"));
      }
      chain.levels.push_back(std::move(l));
    }
  } catch (const nlohmann::json::exception&) {
    return absl::InvalidArgumentError(absl::StrCat(name, ": ", key, ": missing field or wrong type"));
  }
  // Optional (issue 43; absent before baker 0.2.0-bake6 and without a
  // quality pass).
  if (auto q = j.find("quality"); q != j.end() && q->is_object()) {
    if (auto g = q->find("good_up_to_pixels"); g != q->end()) {
      if (!g->is_number_unsigned()) {
        return absl::InvalidArgumentError(name + ": quality.good_up_to_pixels: not a whole number");
      }
      chain.good_up_to_pixels = g->get<uint32_t>();
    }
  }
  if (chain.levels.back().kind != LodLevelInfo::Kind::kImpostor) {
    return absl::InvalidArgumentError(name + ": lods: the last level is not the impostor");
  }
  return chain;
}

}  // namespace impostor::sdk
