#include "common/manifest/geometry_manifest_json.h"

#include <array>
#include <vector>

namespace impostor {

using nlohmann::json;

void AddGeometryJson(const v1::Manifest& m, json* j) {
  const v1::BoundingBox& box = m.bounding_box();
  if (box.min_size() == 3 && box.max_size() == 3) {
    (*j)["bounding_box"] = {{"min", std::vector<float>(box.min().begin(), box.min().end())},
                            {"max", std::vector<float>(box.max().begin(), box.max().end())}};
  }
  const v1::Cutout& cutout = m.cutout();
  if (cutout.vertices_size() >= 6) {
    json vertices = json::array();
    for (int i = 0; i + 1 < cutout.vertices_size(); i += 2) {
      vertices.push_back({cutout.vertices(i), cutout.vertices(i + 1)});
    }
    (*j)["cutout"] = {{"vertices", vertices}, {"area_ratio", cutout.area_ratio()}};
  }
}

absl::Status ReadGeometryJson(const json& j, v1::Manifest* m) {
  if (auto it = j.find("bounding_box"); it != j.end()) {
    const auto bad = absl::InvalidArgumentError("manifest.json: bounding_box: expected {min: [x,y,z], max: [x,y,z]}");
    if (!it->is_object()) return bad;
    try {
      const auto min = it->at("min").get<std::array<float, 3>>();
      const auto max = it->at("max").get<std::array<float, 3>>();
      for (float f : min) m->mutable_bounding_box()->add_min(f);
      for (float f : max) m->mutable_bounding_box()->add_max(f);
    } catch (const json::exception&) {
      return bad;
    }
  }
  if (auto it = j.find("cutout"); it != j.end()) {
    const auto bad = absl::InvalidArgumentError(
        "manifest.json: cutout: expected {vertices: [[u, v], ...] (3..64 of them), area_ratio}");
    if (!it->is_object()) return bad;
    try {
      const auto vertices = it->at("vertices").get<std::vector<std::array<float, 2>>>();
      if (vertices.size() < 3 || vertices.size() > 64) return bad;
      for (const auto& v : vertices) {
        m->mutable_cutout()->add_vertices(v[0]);
        m->mutable_cutout()->add_vertices(v[1]);
      }
      m->mutable_cutout()->set_area_ratio(it->at("area_ratio").get<float>());
    } catch (const json::exception&) {
      return bad;
    }
  }
  return absl::OkStatus();
}

}  // namespace impostor
