#include "common/manifest_json.h"

#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

using nlohmann::json;

json DigestJson(const v1::Digest& d) { return {{"hash", d.hash()}, {"size_bytes", d.size_bytes()}}; }

json Vec(const google::protobuf::RepeatedField<float>& v) { return json(std::vector<float>(v.begin(), v.end())); }

// Reads `j[key]` as T or records the first error.
class Reader {
 public:
  template <typename T>
  T Get(const json& j, const char* key, std::string_view path) {
    if (!error_.empty()) return T{};
    auto it = j.find(key);
    if (it == j.end()) {
      error_ = absl::StrCat(std::string(path), key, ": missing");
      return T{};
    }
    try {
      return it->get<T>();
    } catch (const json::exception&) {
      error_ = absl::StrCat(std::string(path), key, ": wrong type");
      return T{};
    }
  }
  const json& Obj(const json& j, const char* key, std::string_view path) {
    static const json kEmpty = json::object();
    if (!error_.empty()) return kEmpty;
    auto it = j.find(key);
    if (it == j.end() || !(it->is_object() || it->is_array())) {
      error_ = absl::StrCat(std::string(path), key, ": missing or not an object/array");
      return kEmpty;
    }
    return *it;
  }
  void Floats(const json& j, const char* key, std::string_view path, size_t n,
              google::protobuf::RepeatedField<float>* out) {
    auto v = Get<std::vector<float>>(j, key, path);
    if (error_.empty() && v.size() != n) {
      error_ = absl::StrCat(std::string(path), key, ": expected ", n, " numbers");
    }
    for (float f : v) out->Add(f);
  }
  void Digest(const json& j, std::string_view path, v1::Digest* d) {
    const json& o = Obj(j, "digest", path);
    d->set_hash(Get<std::string>(o, "hash", absl::StrCat(std::string(path), "digest.")));
    d->set_size_bytes(Get<int64_t>(o, "size_bytes", absl::StrCat(std::string(path), "digest.")));
  }
  const std::string& error() const { return error_; }

 private:
  std::string error_;
};

}  // namespace

std::string_view LayoutJsonName(v1::Layout layout) {
  switch (layout) {
    case v1::LAYOUT_OCTAHEDRAL: return "octahedral";
    case v1::LAYOUT_HEMI_OCTAHEDRAL: return "hemi-octahedral";
    default: return "unspecified";
  }
}

std::string ManifestToJson(const v1::Manifest& m) {
  json j;
  j["format_version"] = m.format_version();
  j["cache_key"] = m.cache_key();
  j["baker_version"] = m.baker_version();
  j["layout"] = std::string(LayoutJsonName(m.layout()));
  j["frames"] = m.frames();
  j["resolution"] = m.resolution();
  j["tile_size"] = m.tile_size();
  j["bounding_sphere"] = {{"center", Vec(m.bounding_sphere().center())},
                          {"radius", m.bounding_sphere().radius()}};
  json maps = json::array();
  for (const auto& map : m.maps()) {
    maps.push_back({{"semantic", map.semantic()},
                    {"file", map.file()},
                    {"digest", DigestJson(map.digest())},
                    {"width", map.width()},
                    {"height", map.height()},
                    {"format", map.format()},
                    {"channels", std::vector<std::string>(map.channels().begin(), map.channels().end())}});
  }
  j["maps"] = maps;
  json views = json::array();
  for (const auto& v : m.views()) {
    views.push_back({{"index", v.index()},
                     {"direction", Vec(v.direction())},
                     {"up", Vec(v.up())},
                     {"tile", {v.tile().x(), v.tile().y(), v.tile().width(), v.tile().height()}},
                     {"same_view_as", v.same_view_as()}});
  }
  j["views"] = views;
  j["mesh"] = {{"triangles", m.mesh().triangles()},
               {"materials", m.mesh().materials()},
               {"textures", m.mesh().textures()}};
  const auto& t = m.timings();
  j["timings_seconds"] = {{"download", t.download_seconds()}, {"load", t.load_seconds()},
                          {"render", t.render_seconds()},     {"readback", t.readback_seconds()},
                          {"encode", t.encode_seconds()},     {"store", t.store_seconds()},
                          {"total", t.total_seconds()}};
  j["device"] = m.device();
  return j.dump(2) + "\n";
}

absl::StatusOr<v1::Manifest> ManifestFromJson(std::string_view text) {
  json j = json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) {
    return absl::InvalidArgumentError("manifest.json: not a JSON object");
  }
  Reader r;
  v1::Manifest m;
  m.set_format_version(r.Get<uint32_t>(j, "format_version", ""));
  if (r.error().empty() && m.format_version() != kManifestFormatVersion) {
    return absl::InvalidArgumentError(absl::StrCat("manifest.json: format_version ", m.format_version(),
                                                   " is not supported (expected ", kManifestFormatVersion, ")"));
  }
  m.set_cache_key(r.Get<std::string>(j, "cache_key", ""));
  m.set_baker_version(r.Get<std::string>(j, "baker_version", ""));
  const std::string layout = r.Get<std::string>(j, "layout", "");
  if (layout == "octahedral") m.set_layout(v1::LAYOUT_OCTAHEDRAL);
  else if (layout == "hemi-octahedral") m.set_layout(v1::LAYOUT_HEMI_OCTAHEDRAL);
  else if (r.error().empty()) return absl::InvalidArgumentError("manifest.json: layout: unknown \"" + layout + "\"");
  m.set_frames(r.Get<uint32_t>(j, "frames", ""));
  m.set_resolution(r.Get<uint32_t>(j, "resolution", ""));
  m.set_tile_size(r.Get<uint32_t>(j, "tile_size", ""));
  const json& sphere = r.Obj(j, "bounding_sphere", "");
  r.Floats(sphere, "center", "bounding_sphere.", 3, m.mutable_bounding_sphere()->mutable_center());
  m.mutable_bounding_sphere()->set_radius(r.Get<float>(sphere, "radius", "bounding_sphere."));
  const json& maps = r.Obj(j, "maps", "");
  for (size_t i = 0; r.error().empty() && i < maps.size(); ++i) {
    const std::string path = absl::StrCat("maps[", i, "].");
    v1::MapFile* map = m.add_maps();
    map->set_semantic(r.Get<std::string>(maps[i], "semantic", path));
    map->set_file(r.Get<std::string>(maps[i], "file", path));
    r.Digest(maps[i], path, map->mutable_digest());
    map->set_width(r.Get<uint32_t>(maps[i], "width", path));
    map->set_height(r.Get<uint32_t>(maps[i], "height", path));
    map->set_format(r.Get<std::string>(maps[i], "format", path));
    for (const auto& c : r.Get<std::vector<std::string>>(maps[i], "channels", path)) map->add_channels(c);
  }
  const json& views = r.Obj(j, "views", "");
  for (size_t i = 0; r.error().empty() && i < views.size(); ++i) {
    const std::string path = absl::StrCat("views[", i, "].");
    v1::View* v = m.add_views();
    v->set_index(r.Get<uint32_t>(views[i], "index", path));
    r.Floats(views[i], "direction", path, 3, v->mutable_direction());
    r.Floats(views[i], "up", path, 3, v->mutable_up());
    auto tile = r.Get<std::vector<uint32_t>>(views[i], "tile", path);
    if (r.error().empty() && tile.size() != 4) return absl::InvalidArgumentError("manifest.json: " + path + "tile: expected [x, y, w, h]");
    if (tile.size() == 4) {
      v->mutable_tile()->set_x(tile[0]);
      v->mutable_tile()->set_y(tile[1]);
      v->mutable_tile()->set_width(tile[2]);
      v->mutable_tile()->set_height(tile[3]);
    }
    v->set_same_view_as(r.Get<uint32_t>(views[i], "same_view_as", path));
  }
  if (!r.error().empty()) return absl::InvalidArgumentError("manifest.json: " + r.error());
  if (auto it = j.find("device"); it != j.end() && it->is_string()) m.set_device(it->get<std::string>());
  if (auto it = j.find("mesh"); it != j.end() && it->is_object()) {
    m.mutable_mesh()->set_triangles(it->value("triangles", uint64_t{0}));
    m.mutable_mesh()->set_materials(it->value("materials", 0u));
    m.mutable_mesh()->set_textures(it->value("textures", 0u));
  }
  return m;
}

}  // namespace impostor
